"""Modelled catalog objects: the generators' meshes and convex pieces, the catalog entries that use them, their
hull files, and how they behave in SAPIEN."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from robolab_ms.catalog import load_catalog, read_catalog
from robolab_ms.catalog.build import _fingerprint, _stored_fingerprint, build_catalog, build_modelled
from robolab_ms.catalog.check import check_object
from robolab_ms.catalog.meshes import read_hulls
from robolab_ms.catalog.modelled import GENERATORS, generate
from robolab_ms.content import load_yaml
from robolab_ms.errors import SpecError

# Each generator with the sizes asked for: its parameters and the full extent (x, y, z) they must give.
REQUESTS = {
    "revolved": ({"profile": [[0, 0], [0.03, 0], [0.032, 0.05], [0.012, 0.09], [0, 0.09]]}, (0.064, 0.064, 0.09)),
    "mug": ({"radius": 0.045, "height": 0.0975, "handle_reach": 0.025}, (0.115, 0.09, 0.0975)),
    "bowl": ({"radius": 0.0857, "height": 0.0644, "base_radius": 0.05}, (0.1714, 0.1714, 0.0644)),
    "cup": ({"top_radius": 0.04, "bottom_radius": 0.03, "height": 0.09}, (0.08, 0.08, 0.09)),
    "can": ({"radius": 0.033, "height": 0.1}, (0.066, 0.066, 0.1)),
    "bottle": (
        {"radius": 0.028, "height": 0.19, "neck_radius": 0.012, "neck_height": 0.025, "squareness": 0.6},
        (0.056, 0.056, 0.19),
    ),
    "banana": ({"length": 0.205, "radius": 0.018, "bend_deg": 135.0}, (0.1767, 0.0857, 0.036)),
    "drill": ({"height": 0.19, "length": 0.205, "width": 0.075}, (0.205, 0.075, 0.19)),
    "bevelled_box": ({"size": [0.06, 0.16, 0.21]}, (0.06, 0.16, 0.21)),
    "gable_carton": ({"size": [0.07, 0.07, 0.212], "cap_radius": 0.012}, (0.07, 0.07, 0.212)),
    "puzzle_cube": ({"size": 0.057}, (0.057, 0.057, 0.057)),
    "fruit": ({"radius": 0.037, "height": 0.074, "stem_length": 0.0045}, (0.074, 0.074, 0.0761)),
    "bagel": ({"radius": 0.0401, "height": 0.0265, "hole_radius": 0.0136}, (0.0802, 0.0802, 0.0265)),
}


def test_every_generator_has_a_request():
    assert set(REQUESTS) == set(GENERATORS)


@pytest.mark.parametrize("generator", sorted(REQUESTS))
def test_generator_makes_closed_outward_surfaces_of_the_requested_size(generator):
    params, size = REQUESTS[generator]
    model = generate(generator, params)
    low, high = model.bounds
    assert np.allclose(high - low, size, rtol=0.05), (high - low, size)
    assert abs(low[2]) < 1e-9  # it stands on z = 0
    solid = model.solid()  # the surfaces together, merged by position: every edge between two triangles
    assert solid.is_watertight and solid.is_winding_consistent
    assert solid.volume > 0  # wound counter-clockwise seen from outside
    for surface in model.surfaces:
        mesh = surface.mesh
        assert len(mesh.vertices) == len(mesh.normals) == len(mesh.uvs)
        assert np.isfinite(mesh.uvs).all() and mesh.triangles.max() < len(mesh.vertices)
        faces = trimesh.Trimesh(mesh.vertices, mesh.triangles, process=False).face_normals
        shading = mesh.normals[mesh.triangles].mean(axis=1)
        assert np.mean(np.einsum("ij,ij->i", faces, shading) > 0) > 0.98  # the shading normals face outwards
    pieces = np.concatenate(model.pieces)  # the collision covers the same extent as the surfaces
    assert np.allclose(pieces.max(axis=0) - pieces.min(axis=0), high - low, atol=0.004)


def test_flat_bottle_and_lying_or_lobed_fruit_keep_their_size_and_round_parts():
    flat = generate(
        "bottle", {"radius": 0.0475, "depth": 0.062, "height": 0.19, "neck_radius": 0.011, "neck_height": 0.02}
    )
    low, high = flat.bounds
    assert np.allclose(high - low, (0.095, 0.062, 0.19), atol=1e-4)
    assert flat.solid().is_watertight
    cap = np.concatenate([s.mesh.vertices for s in flat.surfaces if s.tint == 1])  # the cap is not squeezed
    assert np.ptp(cap[:, 0]) == pytest.approx(np.ptp(cap[:, 1]), abs=1e-4)
    lime = generate("fruit", {"radius": 0.03, "height": 0.075, "tip": 0.003, "lying": True})
    low, high = lime.bounds
    assert np.allclose(high - low, (0.075, 0.06, 0.06), atol=5e-4) and abs(low[2]) < 1e-9
    pieces = np.concatenate(lime.pieces)
    assert np.allclose(pieces.max(axis=0) - pieces.min(axis=0), high - low, atol=0.004)
    pumpkin = generate(
        "fruit", {"radius": 0.044, "height": 0.087, "stem_length": 0.012, "lobes": 12, "lobe_depth": 0.08}
    )
    low, high = pumpkin.bounds
    assert np.allclose((high - low)[:2], (0.088, 0.088), atol=2e-4)  # the ribs keep the full radius
    body = pumpkin.surfaces[0].mesh
    equator = body.vertices[np.abs(body.vertices[:, 2] - body.vertices[:, 2].max() / 2) < 0.004]
    radial = np.hypot(equator[:, 0], equator[:, 1])
    assert np.ptp(radial) == pytest.approx(0.08 * 0.044, rel=0.2)  # grooves 8 % of the radius deep
    faces = trimesh.Trimesh(body.vertices, body.triangles, process=False).face_normals
    assert np.mean(np.einsum("ij,ij->i", faces, body.normals[body.triangles].mean(axis=1)) > 0) > 0.98


def _inside_a_piece(pieces, point) -> bool:
    """Whether `point` lies inside the convex hull of any of the pieces (vertex arrays)."""
    return any(bool(np.all(ConvexHull(piece).equations @ [*point, 1.0] <= 0.0)) for piece in pieces)


def test_a_mugs_cavity_is_open_and_its_wall_solid():
    params, _ = REQUESTS["mug"]
    model = generate("mug", params)
    depth = model.interior[2]
    floor = params["height"] - depth
    for z in np.linspace(floor + 0.005, params["height"] - 0.002, 6):  # down the middle of the cup
        assert not _inside_a_piece(model.pieces, [0.0, 0.0, z]), z
    for angle in np.radians([0.0, 100.0, 200.0]):  # just inside the inner wall, all around
        point = [0.035 * np.cos(angle), 0.035 * np.sin(angle), 0.05]
        assert not _inside_a_piece(model.pieces, point)
    assert _inside_a_piece(model.pieces, [0.0425 * np.cos(0.1), 0.0425 * np.sin(0.1), 0.05])  # in the wall
    assert _inside_a_piece(model.pieces, [0.0, 0.0, floor / 2])  # in the floor
    assert _inside_a_piece(model.pieces, [0.045 + 0.025 - 0.004, 0.0, 0.052])  # in the handle's far side
    assert not _inside_a_piece(model.pieces, [0.045 + 0.007, 0.0, 0.052])  # through the handle's loop


def test_shipped_mug_hull_file_keeps_the_cavity_open():
    entry = load_catalog()["mug_white"]
    assert entry.is_modelled and len(entry.hulls) > 16
    assert not _inside_a_piece(entry.hulls, [0.0, 0.0, 0.05])
    assert _inside_a_piece(entry.hulls, [0.0425 * np.cos(0.1), 0.0425 * np.sin(0.1), 0.05])


def test_shipped_modelled_hull_files_are_current():
    """A generator changed without `robolab catalog build` would leave hull files that no longer fit the surfaces."""
    catalog = load_catalog()
    modelled = [name for name in catalog.names() if catalog[name].is_modelled]
    assert len(modelled) >= 10
    entries = load_yaml(catalog.file)["objects"]
    for name in modelled:
        entry = catalog[name]
        expected = _fingerprint(name, entries[name], model_digest=entry.model.digest())
        assert _stored_fingerprint(entry.collision_file) == expected, f"{name}: run 'robolab catalog build'"
        low, high = entry.model.bounds
        assert np.allclose(high - low, entry.recorded_dimensions, atol=1e-4), name


ENTRIES = """\
version: 1
objects:
  test_mug:
    class: container
    description: a test mug
    colors: [blue]
    mass: 0.3
    friction: {static: 0.8, dynamic: 0.6}
    container: true
    source: {kind: modelled, generator: mug, params: {radius: 0.045, height: 0.0975}}
    collision: {method: modelled_pieces}
    license: test
  test_banana:
    class: fruit
    description: a test banana
    colors: [yellow]
    mass: 0.12
    friction: {static: 0.9, dynamic: 0.7}
    source: {kind: modelled, generator: banana, params: {length: 0.205, radius: 0.018, bend_deg: 135}}
    collision: {method: modelled_pieces}
    license: test
"""


def test_modelled_entries_build_load_and_rest_in_sapien(tmp_path):
    file = tmp_path / "catalog.yaml"
    file.write_text(ENTRIES)
    report = build_catalog(file, progress=lambda line: None)
    assert sorted(report.built) == ["test_banana", "test_mug"]
    assert build_catalog(file, progress=lambda line: None).built == []  # idempotent
    catalog = read_catalog(file)
    mug = catalog["test_mug"]
    assert mug.is_modelled and not mug.is_procedural and mug.visual_files() == []
    assert (tmp_path / "collision" / "test_mug.obj").is_file()
    assert len(read_hulls(str(mug.collision_file))) == len(mug.model.pieces)
    assert np.allclose(mug.recorded_dimensions, [0.1151, 0.09, 0.0975], atol=2e-4)
    assert mug.interior is not None and mug.interior[0] == pytest.approx(0.08, abs=0.002)
    assert np.allclose(mug.dimensions, mug.recorded_dimensions, atol=0.002)  # the hulls span the visual size
    for name in ("test_mug", "test_banana"):
        result = check_object(catalog[name], render=False)  # loads, rests, has its size and mass; the mug holds
        assert result.passed, result.problems

    text = file.read_text().replace("bend_deg: 135", "bend_deg: 100")
    file.write_text(text)
    assert build_catalog(file, progress=lambda line: None).built == ["test_banana"]  # new parameters, new hulls


@pytest.mark.parametrize(
    ("change", "field", "match"),
    [
        ("generator: mug", "source.generator", "not one of"),
        ("radius: 0.045", "source.params.radius", "positive"),
        ("height: 0.0975}", "source.params.colour", "not a parameter"),
        ("radius: 0.045", "source.params", "too thick"),
        ("collision: {method: modelled_pieces}", "collision.method", "not one of"),
        ("license: test", "transform", "modelled object"),
    ],
)
def test_bad_modelled_entries_name_file_field_and_fix(tmp_path, change, field, match):
    replacement = {
        "generator: mug": "generator: mugg",
        "radius: 0.045": "radius: -0.045" if field.endswith("radius") else "radius: 0.045, wall: 0.03",
        "height: 0.0975}": "height: 0.0975, colour: 1}",
        "collision: {method: modelled_pieces}": "collision: {method: primitives}",
        "license: test": "license: test\n    transform: {scale: 1}",
    }[change]
    file = tmp_path / "catalog.yaml"
    file.write_text(
        ENTRIES.replace(change, replacement, 1).replace(
            "    collision:", "    dimensions: [0.1, 0.1, 0.1]\n    collision:"
        )
    )
    with pytest.raises(SpecError, match=match) as caught:
        read_catalog(file)
    assert caught.value.field == f"objects.test_mug.{field}" and caught.value.file == str(file)


BOX_BY_COACD = """\
version: 1
objects:
  test_box:
    class: box
    description: a test box
    colors: [red]
    mass: 0.2
    friction: {static: 0.8, dynamic: 0.6}
    source: {kind: modelled, generator: bevelled_box, params: {size: [0.04, 0.06, 0.1]}}
    collision: {method: coacd}
    license: test
"""


def test_coacd_decomposes_a_modelled_objects_surfaces(tmp_path, monkeypatch):
    monkeypatch.setenv("ROBOLAB_MS_CACHE", str(tmp_path / "cache"))
    file = tmp_path / "catalog.yaml"
    file.write_text(BOX_BY_COACD)
    entry = load_yaml(file)["objects"]["test_box"]
    notes: dict = {}
    assert build_modelled("test_box", entry, tmp_path / "collision", file, notes=notes)
    assert notes == {"coacd_cached": False} and list((tmp_path / "cache" / "coacd").glob("*.npz"))
    points = np.concatenate(read_hulls(str(tmp_path / "collision" / "test_box.obj")))
    assert np.allclose(points.max(axis=0) - points.min(axis=0), [0.04, 0.06, 0.1], atol=0.003)
    assert entry["dimensions"] == [0.04, 0.06, 0.1]
