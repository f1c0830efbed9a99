"""`robolab catalog add`: mesh files made here by trimesh (OBJ, STL, GLB) go through the CLI into a user content
folder: measured, decomposed by coacd (cached), checked in SAPIEN, pictured, and usable by scenes; bad files are
refused with the file and a fix, and leave nothing behind."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from robolab_ms.catalog import load_catalog, read_catalog
from robolab_ms.catalog.add import CLASS_DENSITY, TO_FILL
from robolab_ms.catalog.build import build_catalog
from robolab_ms.cli import main
from robolab_ms.content import CACHE_ENV, CONTENT_ENV
from robolab_ms.errors import RoboLabError, SpecError

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    """A fresh coacd cache per test, and no user content folders from the environment."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.delenv(CONTENT_ENV, raising=False)


def add(capsys, *args: str) -> tuple[int, str, str]:
    """Run `robolab catalog add ARGS` in this process: exit code, stdout, stderr."""
    code = main(["catalog", "add", *args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def write_mesh(path: Path, mesh: trimesh.Trimesh) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(path)
    return path


def torus() -> trimesh.Trimesh:
    return trimesh.creation.torus(0.05, 0.015, major_sections=24, minor_sections=10)


def test_a_box_in_millimetres_is_refused_then_added_with_its_scale(tmp_path, capsys):
    mesh = write_mesh(tmp_path / "box_mm.obj", trimesh.creation.box([60.0, 40.0, 90.0]))
    content = tmp_path / "mine"
    code, _, err = add(capsys, str(mesh), "--name", "parcel", "--class", "box", "--content", str(content))
    assert code == 2 and str(mesh) in err and "too large" in err and "--scale 0.001" in err
    assert not content.exists()  # nothing written

    code, out, err = add(
        capsys, str(mesh), "--name", "parcel", "--class", "box", "--content", str(content), "--scale", "0.001"
    )
    assert code == 0, err
    catalog_file = content / "assets" / "catalog.yaml"
    assert f"added 'parcel' to {catalog_file}" in out and TO_FILL in out
    entry = read_catalog(catalog_file)["parcel"]
    assert np.allclose(entry.recorded_dimensions, [0.06, 0.04, 0.09], atol=1e-4)
    assert np.allclose(entry.bounds, [[-0.03, -0.02, 0.0], [0.03, 0.02, 0.09]], atol=1e-3)  # bottom centre at 0
    assert entry.source["kind"] == "file" and entry.source["origin"].startswith(TO_FILL)
    assert entry.license.startswith(TO_FILL)
    assert entry.shape == "modelled"  # a mesh of the user's own, unless --shape says otherwise
    assert entry.visual_files() == [content / "assets" / "meshes" / "parcel" / "box_mm.obj"]
    assert entry.collision_file == content / "assets" / "collision" / "parcel.obj" and entry.collision_file.is_file()
    assert entry.mass == pytest.approx(CLASS_DENSITY["box"] * 0.06 * 0.04 * 0.09, rel=0.01)
    sheet = np.asarray(Image.open(content / "assets" / "contact_sheet.png").convert("RGB"))
    assert len(np.unique(sheet.reshape(-1, 3), axis=0)) > 20  # the object was drawn


def test_a_torus_keeps_its_hole_and_coacd_runs_once_per_mesh(tmp_path, capsys):
    mesh = write_mesh(tmp_path / "ring.stl", torus())
    content = tmp_path / "mine"
    code, out, err = add(
        capsys,
        str(mesh),
        "--name",
        "ring",
        "--class",
        "toy",
        "--mass",
        "0.08",
        "--colors",
        "orange",
        "--content",
        str(content),
        "--no-sheet",
        "--shape",
        "primitive",
    )
    assert code == 0, err
    assert "coacd: cached" not in out and len(list((tmp_path / "cache" / "coacd").glob("*.npz"))) == 1
    entry = read_catalog(content / "assets" / "catalog.yaml")["ring"]
    assert entry.mass == 0.08 and entry.colors == ("orange",) and entry.shape == "primitive"  # a torus
    assert len(entry.hulls) > 4  # a convex decomposition, not one hull
    centre = np.array([[0.0, 0.0, entry.recorded_dimensions[2] / 2]])
    assert not any(trimesh.convex.convex_hull(hull).contains(centre)[0] for hull in entry.hulls)  # the hole is free

    code, out, err = add(
        capsys, str(mesh), "--name", "ring_again", "--class", "toy", "--content", str(content), "--no-sheet"
    )
    assert code == 0, err
    assert "coacd: cached" in out and len(list((tmp_path / "cache" / "coacd").glob("*.npz"))) == 1
    again = read_catalog(content / "assets" / "catalog.yaml")["ring_again"]
    assert len(again.hulls) == len(entry.hulls)


def test_a_glb_stands_up_from_gltf_y_up_and_meshes_keep_their_textures(tmp_path, capsys):
    tall = trimesh.creation.box([0.05, 0.12, 0.03])  # long along y, as a glTF file stores an upright object
    tall.unmerge_vertices()
    uv = (tall.vertices[:, :2] - tall.vertices[:, :2].min(0)) / np.ptp(tall.vertices[:, :2], axis=0)
    image = np.full((32, 32, 3), 230, np.uint8)
    image[:16, :16] = (30, 160, 30)
    tall.visual = trimesh.visual.TextureVisuals(uv=uv, image=Image.fromarray(image))
    mesh = write_mesh(tmp_path / "tower.glb", tall)
    content = tmp_path / "mine"
    code, _, err = add(capsys, str(mesh), "--name", "tower", "--class", "toy", "--content", str(content))
    assert code == 0, err
    entry = read_catalog(content / "assets" / "catalog.yaml")["tower"]
    assert np.allclose(entry.recorded_dimensions, [0.05, 0.03, 0.12], atol=1e-4)
    assert entry.source["textured"] is True

    code, _, err = add(
        capsys,
        str(mesh),
        "--name",
        "tower_lying",
        "--class",
        "toy",
        "--up",
        "z",
        "--content",
        str(content),
        "--no-sheet",
    )
    assert code == 0, err
    lying = read_catalog(content / "assets" / "catalog.yaml")["tower_lying"]
    assert np.allclose(lying.recorded_dimensions, [0.05, 0.12, 0.03], atol=1e-4)

    obj = write_mesh(tmp_path / "obj" / "tower.obj", tall)  # with material.mtl and its texture beside it
    code, _, err = add(
        capsys, str(obj), "--name", "tower_obj", "--class", "toy", "--up", "y", "--content", str(content), "--no-sheet"
    )
    assert code == 0, err
    copied = read_catalog(content / "assets" / "catalog.yaml")["tower_obj"]
    assert copied.source["textured"] is True
    assert sorted(path.name for path in copied.visual_files()[0].parent.iterdir()) == sorted(
        path.name for path in obj.parent.iterdir()
    )  # the material library and its texture came along
    assert np.allclose(copied.recorded_dimensions, [0.05, 0.03, 0.12], atol=1e-4)


def two_boxes_sharing_an_edge() -> trimesh.Trimesh:
    a = trimesh.creation.box([0.04, 0.04, 0.04])
    b = trimesh.creation.box([0.04, 0.04, 0.04])
    b.apply_translation([0.04, 0.0, 0.04])
    return trimesh.util.concatenate([a, b])


def open_tube() -> trimesh.Trimesh:
    cylinder = trimesh.creation.cylinder(0.03, 0.1, sections=24)
    return trimesh.Trimesh(cylinder.vertices, cylinder.faces[np.abs(cylinder.face_normals[:, 2]) < 0.5])


BAD_MESHES = {
    "empty.obj": (lambda path: path.write_bytes(b""), "is empty (0 bytes)", "Export the mesh again"),
    "noise.glb": (lambda path: path.write_bytes(np.random.default_rng(0).bytes(600)), "cannot be read as a GLB mesh",
                  "export it again"),
    "noise.stl": (lambda path: path.write_bytes(np.random.default_rng(1).bytes(600)), "holds no triangles",
                  "triangle mesh"),
    "points.obj": (lambda path: path.write_text("v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\n"), "holds no triangles",
                   "triangle mesh"),
    "tube.stl": (lambda path: open_tube().export(path), "is not a closed surface", "--allow-open"),
    "fin.obj": (lambda path: two_boxes_sharing_an_edge().export(path), "shared by more than two triangles",
                "--allow-open"),
    "sheet.obj": (lambda path: trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0], [0, 0.1, 0]],
                                               [[0, 1, 2], [0, 2, 3]]).export(path), "is flat", "thickness"),
    "lorry.stl": (lambda path: trimesh.creation.box([2.0, 1.0, 1.0]).export(path), "too large", "--scale"),
    "grain.stl": (lambda path: trimesh.creation.box([0.002, 0.002, 0.001]).export(path), "too small", "--scale"),
    "model.ply": (lambda path: trimesh.creation.box([0.1, 0.1, 0.1]).export(path), "not one of .obj, .glb, .stl",
                  "Export it as OBJ, GLB or STL"),
}  # fmt: skip


@pytest.mark.parametrize("file_name", list(BAD_MESHES))
def test_bad_meshes_are_refused_naming_the_file_and_a_fix(tmp_path, capsys, file_name):
    make, problem, fix = BAD_MESHES[file_name]
    path = tmp_path / file_name
    make(path)
    content = tmp_path / "mine"
    code, out, err = add(capsys, str(path), "--name", "thing", "--class", "other", "--content", str(content))
    assert code == 2 and "Traceback" not in err
    assert f"robolab: error: {path}: " in err and problem in err and fix in err
    assert not content.exists()


def test_repairs_are_made_and_reported_and_a_missing_file_is_named(tmp_path, capsys):
    box = trimesh.creation.box([0.08, 0.08, 0.05])
    lidless = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] < 0.5])  # its top is a square hole
    mesh = write_mesh(tmp_path / "tray.obj", lidless)
    code, out, err = add(
        capsys, str(mesh), "--name", "tray_box", "--class", "box", "--content", str(tmp_path / "mine"), "--no-sheet"
    )
    assert code == 0, err
    assert "repaired: filled holes" in out

    code, _, err = add(capsys, str(tmp_path / "nowhere.obj"), "--name", "x", "--class", "box")
    assert code == 2 and f"{tmp_path / 'nowhere.obj'}: does not exist" in err


def test_an_object_that_fails_the_sapien_check_leaves_nothing_behind(tmp_path, capsys):
    leaning = trimesh.convex.convex_hull(
        np.array(
            [  # its top overhangs its foot: it falls over
                [0, 0, 0],
                [0.02, 0, 0],
                [0, 0.03, 0],
                [0.02, 0.03, 0],
                [0.1, 0, 0.1],
                [0.12, 0, 0.1],
                [0.1, 0.03, 0.1],
                [0.12, 0.03, 0.1],
            ],
            dtype=float,
        )
    )
    content = tmp_path / "mine"
    first = write_mesh(tmp_path / "block.stl", trimesh.creation.box([0.05, 0.05, 0.05]))
    assert (
        add(capsys, str(first), "--name", "cube_five", "--class", "block", "--content", str(content), "--no-sheet")[0]
        == 0
    )
    catalog_file = content / "assets" / "catalog.yaml"
    before = catalog_file.read_text()
    mesh = write_mesh(tmp_path / "leaning.stl", leaning)
    code, _, err = add(capsys, str(mesh), "--name", "leaning", "--class", "block", "--content", str(content))
    assert code == 2 and f"{mesh}: as catalog object 'leaning' it fails the SAPIEN check" in err
    assert "--up" in err and "Traceback" not in err
    assert catalog_file.read_text() == before
    assert not (content / "assets" / "meshes" / "leaning").exists()
    assert not (content / "assets" / "collision" / "leaning.obj").exists()
    assert sorted(path.name for path in (content / "assets" / "meshes").iterdir()) == ["cube_five"]


def test_names_are_unique_and_replace_replaces(tmp_path, capsys):
    mesh = write_mesh(tmp_path / "block.stl", trimesh.creation.box([0.05, 0.05, 0.05]))
    content = tmp_path / "mine"
    code, _, err = add(capsys, str(mesh), "--name", "banana", "--class", "fruit", "--content", str(content))
    assert code == 2 and "'banana' already exists" in err and not content.exists()
    code, _, err = add(capsys, str(mesh), "--name", "red cube", "--class", "block", "--content", str(content))
    assert code == 2 and "letters, digits and underscores" in err
    code, _, err = add(capsys, str(mesh), "--name", "cube", "--class", "blok", "--content", str(content))
    assert code == 2 and "Did you mean 'block'" in err

    assert add(capsys, str(mesh), "--name", "cube", "--class", "block", "--content", str(content), "--no-sheet")[0] == 0
    code, _, err = add(capsys, str(mesh), "--name", "cube", "--class", "block", "--content", str(content))
    assert code == 2 and "already in" in err and "--replace" in err
    bigger = write_mesh(tmp_path / "bigger.stl", trimesh.creation.box([0.07, 0.07, 0.07]))
    code, _, err = add(
        capsys, str(bigger), "--name", "cube", "--class", "block", "--content", str(content), "--replace", "--no-sheet"
    )
    assert code == 0, err
    catalog = read_catalog(content / "assets" / "catalog.yaml")
    assert catalog.names() == ["cube"] and np.allclose(catalog["cube"].recorded_dimensions, 0.07, atol=1e-4)
    assert [path.name for path in (content / "assets" / "meshes" / "cube").iterdir()] == ["bigger.stl"]


SCENE = """
name: my_ring_scene
description: A ring of my own beside a banana.
table: {size: [0.9, 1.2], color: white}
objects:
  - {name: ring, asset: my_ring, xy: [0.5, 0.15]}
  - {name: banana, asset: banana, xy: [0.5, -0.15], yaw_deg: 20}
"""

TASK = """
name: MyRingTask
scene: my_ring_scene
episode_seconds: 4
attributes: [spatial]
instructions: {default: Put the banana in the ring., vague: Tidy up., specific: Put the yellow banana in the ring.}
success:
  - {predicate: on_top, objects: [banana], reference: ring}
"""


@pytest.mark.slow
def test_a_scene_in_the_same_content_folder_places_the_new_object(tmp_path, capsys):
    content = tmp_path / "mine"
    mesh = write_mesh(tmp_path / "ring.obj", torus())
    code, _, err = add(
        capsys, str(mesh), "--name", "my_ring", "--class", "toy", "--content", str(content), "--no-sheet"
    )
    assert code == 0, err
    (content / "scene_builders").mkdir()
    (content / "scene_builders" / "my_ring_scene.yaml").write_text(SCENE)
    (content / "task_specs").mkdir()
    (content / "task_specs" / "MyRingTask.yaml").write_text(TASK)

    environment = {**os.environ, "PYTHONPATH": str(REPO), CONTENT_ENV: str(content)}

    def robolab(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "robolab_ms.cli", *args],
            capture_output=True,
            text=True,
            env=environment,
            timeout=600,
        )

    listing = robolab("catalog", "list")
    assert listing.returncode == 0, listing.stderr
    row = next(line for line in listing.stdout.splitlines() if line.startswith("my_ring "))
    assert f"file in {content / 'assets'}" in row
    tasks = robolab("list")
    assert tasks.returncode == 0 and any(line.startswith("MyRingTask") for line in tasks.stdout.splitlines())
    out = tmp_path / "run"
    evaluated = robolab(
        "eval",
        "--policy",
        "random",
        "--task",
        "MyRingTask",
        "--episodes",
        "1",
        "--max-steps",
        "3",
        "--out",
        str(out),
        "--quiet",
    )
    assert evaluated.returncode == 0, evaluated.stderr
    (episode,) = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert episode["task"] == "MyRingTask" and episode["steps"] == 3 and episode["error"] is None


def test_user_catalogs_are_checked_joined_and_rebuilt(tmp_path, capsys, monkeypatch):
    content = tmp_path / "mine"
    mesh = write_mesh(tmp_path / "block.stl", trimesh.creation.box([0.05, 0.05, 0.05]))
    assert (
        add(capsys, str(mesh), "--name", "my_cube", "--class", "block", "--content", str(content), "--no-sheet")[0] == 0
    )
    catalog_file = content / "assets" / "catalog.yaml"
    assert "my_cube" not in load_catalog()
    monkeypatch.setenv(CONTENT_ENV, str(content))
    joined = load_catalog()
    assert "my_cube" in joined and "banana" in joined

    report = build_catalog(catalog_file, progress=lambda line: None)  # `robolab catalog build --catalog FILE`
    assert report.built == [] and report.skipped == ["my_cube"] and not report.catalog_changed
    (content / "assets" / "meshes" / "my_cube" / "block.stl").write_bytes(
        trimesh.exchange.stl.export_stl(trimesh.creation.box([0.05, 0.05, 0.08]))
    )  # the file changed: rebuilt
    report = build_catalog(catalog_file, progress=lambda line: None)
    assert report.built == ["my_cube"]
    assert np.allclose(read_catalog(catalog_file)["my_cube"].recorded_dimensions, [0.05, 0.05, 0.08], atol=1e-4)

    text = catalog_file.read_text()
    catalog_file.write_text(text.replace("my_cube:", "banana:"))
    with pytest.raises(RoboLabError, match="catalog object 'banana' is defined twice"):
        load_catalog()
    catalog_file.write_text(text.replace("meshes/my_cube/block.stl", "meshes/my_cube/gone.stl"))
    with pytest.raises(SpecError, match=r"objects.my_cube.source.paths\[0\].*not a file beside the catalog file"):
        load_catalog()
