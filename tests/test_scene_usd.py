"""Scenes in USD: `robolab scene export` writes a stage that USD opens and validates (also after the folder moves),
with the poses, bodies, masses and colliders of the scene; `robolab scene import` reads it back with every pose
kept to 1e-6, and reads layouts made elsewhere (other units, other names, a --map file, supports from heights)."""

from __future__ import annotations

import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

from robolab_ms.catalog import load_catalog
from robolab_ms.catalog.procedural import quat_multiply, quat_to_matrix, yaw_quat
from robolab_ms.errors import RoboLabError, SpecError
from robolab_ms.scene import load_scene, read_scene
from robolab_ms.scene.support import drop_height, placed_pieces
from robolab_ms.scene.usd_export import ASSETS_FOLDER, export_scene
from robolab_ms.scene.usd_import import import_scene, yaw_and_tilt
from robolab_ms.scene.usd_stage import validate_stage

ROBOLAB = [sys.executable, "-m", "robolab_ms.cli"]
POSE_TOLERANCE = 1e-6
# RoboLab layouts with a wooden rack, a chrome wire shelf and a storage rack (fixtures, levels), objects in crates
# and bins, a three-cube stack, tilted objects, textured package meshes, and our own scene with a table material,
# background and jitter of its own
SCENES = [
    "mugs_on_shelf",
    "wire_shelf_mugs_plate_spatula",
    "shelf_with_cleaning_products",
    "bananas_5_in_crate",
    "rubiks_cube_3",
    "cartons_in_crate",
    "bin_condiments",
    "kitchen_table",
]


@pytest.fixture(scope="module")
def catalog():
    return load_catalog()


def quaternion(placement) -> np.ndarray:
    return np.array(quat_multiply(yaw_quat(placement.yaw), placement.tilt))


def rotation_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Largest component difference of two unit quaternions, sign-free (q and -q are one rotation)."""
    return float(min(np.abs(a - b).max(), np.abs(a + b).max()))


@pytest.mark.parametrize("name", SCENES)
def test_round_trip_keeps_every_pose(tmp_path, catalog, name):
    """Every body of the exported stage stands at the source scene's pose (translate, orient) to 1e-6; importing the
    stage gives a scene file whose every pose, support, level and table setting equals the source's."""
    source = load_scene(name)
    usd = tmp_path / f"{name}.usda"
    export_scene(source, usd, catalog)
    stage = Usd.Stage.Open(str(usd))
    for placement in source.objects:
        body = next(
            prim
            for prim in stage.GetPrimAtPath("/World").GetChildren()
            if prim.GetAttribute("robolab:name").Get() == placement.name
        )
        translate = np.array(body.GetAttribute("xformOp:translate").Get())
        orient = body.GetAttribute("xformOp:orient").Get()
        orient = np.array([orient.GetReal(), *orient.GetImaginary()])
        assert np.abs(translate - [*placement.xy, placement.z]).max() <= POSE_TOLERANCE, placement.name
        assert rotation_gap(orient, quaternion(placement)) <= POSE_TOLERANCE, placement.name
    report = import_scene(usd, tmp_path / "scene_builders" / f"{name}.yaml", catalog=catalog)
    back = read_scene(report.scene_file, catalog)  # the normal scene loader
    assert back.object_names() == source.object_names()
    for placement in source.objects:
        other = back.placement(placement.name)
        assert (other.asset, other.on, other.level, other.fixture) == (
            placement.asset,
            placement.on,
            placement.level,
            placement.fixture,
        ), placement.name
        assert np.abs(np.subtract(other.xy, placement.xy)).max() <= POSE_TOLERANCE, placement.name
        assert abs(other.z - placement.z) <= POSE_TOLERANCE, placement.name
        assert rotation_gap(quaternion(other), quaternion(placement)) <= POSE_TOLERANCE, placement.name
    assert (back.table_size, back.table_rgba, back.table_material, back.background, back.description) == (
        source.table_size,
        source.table_rgba,
        source.table_material,
        source.background,
        source.description,
    )
    assert abs(back.jitter_xy - source.jitter_xy) < 1e-9 and abs(back.jitter_yaw - source.jitter_yaw) < 1e-9
    assert report.notes == []


def test_stage_bodies_masses_and_colliders(tmp_path, catalog):
    """The stage's conventions and physics: Z up, metres, kilograms; static table and stand; one rigid body per
    object with the catalog mass, fixtures kinematic; primitives or convex-hull pieces as colliders, whose bounds
    are the catalog object's collision bounds; visual meshes where the collision is."""
    usd = tmp_path / "kitchen.usda"
    spec = load_scene("kitchen_table")
    report = export_scene(spec, usd, catalog)
    assert report.problems == [] and validate_stage(usd) == []
    stage = Usd.Stage.Open(str(usd))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdPhysics.GetStageKilogramsPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == Sdf.Path("/World")
    assert stage.GetPrimAtPath("/PhysicsScene").IsA(UsdPhysics.Scene)
    for static in ("/World/table", "/World/robot_pedestal"):
        prim = stage.GetPrimAtPath(static)
        assert prim.HasAPI(UsdPhysics.CollisionAPI) and not prim.HasAPI(UsdPhysics.RigidBodyAPI)
    top = (
        UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
        .ComputeWorldBound(stage.GetPrimAtPath("/World/table"))
        .ComputeAlignedRange()
    )
    assert abs(top.GetMax()[2]) < 1e-12 and np.allclose(np.array(top.GetMax() - top.GetMin())[:2], spec.table_size)
    guide = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.guide])
    render = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    kinds = set()
    for placement in spec.objects:
        entry = catalog[placement.asset]
        body = stage.GetPrimAtPath(f"/World/{placement.name}")
        assert body.GetAttribute("robolab:catalog").Get() == placement.asset
        assert body.HasAPI(UsdPhysics.RigidBodyAPI) and body.HasAPI(UsdPhysics.MassAPI)
        assert UsdPhysics.MassAPI(body).GetMassAttr().Get() == pytest.approx(entry.mass, rel=1e-6)
        assert bool(UsdPhysics.RigidBodyAPI(body).GetKinematicEnabledAttr().Get()) == placement.fixture
        colliders = [prim for prim in Usd.PrimRange(body) if prim.HasAPI(UsdPhysics.CollisionAPI)]
        visual = (
            np.array(render.ComputeUntransformedBound(body).ComputeAlignedRange().GetMin()),
            np.array(render.ComputeUntransformedBound(body).ComputeAlignedRange().GetMax()),
        )
        if entry.parts:
            kinds.add("procedural")
            assert len(colliders) == len(entry.parts)
            assert np.abs(np.stack(visual) - entry.exact_bounds).max() < 1e-6, placement.name
        else:
            kinds.add("mesh")
            assert len(colliders) == len(entry.hulls)
            assert all(
                UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get() == "convexHull" for prim in colliders
            )
            hulls = guide.ComputeUntransformedBound(body).ComputeAlignedRange()
            assert np.abs(np.array([hulls.GetMin(), hulls.GetMax()]) - entry.bounds).max() < 1e-5, placement.name
            assert np.abs(np.stack(visual) - entry.bounds).max() < 0.005, placement.name  # visual mesh ~ its hulls
    assert kinds == {"procedural", "mesh"}
    shelf = load_scene("mugs_on_shelf")
    export_scene(shelf, tmp_path / "shelf.usda", catalog)
    shelf_stage = Usd.Stage.Open(str(tmp_path / "shelf.usda"))
    rack = shelf_stage.GetPrimAtPath("/World/rack_l04")
    assert UsdPhysics.RigidBodyAPI(rack).GetKinematicEnabledAttr().Get() is True


def test_moved_folder_still_opens(tmp_path, catalog):
    """The scene refers to its assets and textures by relative paths: moved with its assets folder it opens with
    no composition error and passes the checks; without a texture the check names it."""
    first = tmp_path / "first" / "bin_condiments.usda"
    export_scene(load_scene("bin_condiments"), first, catalog)
    assert str(tmp_path) not in first.read_text()
    moved = tmp_path / "elsewhere" / "deeper"
    moved.parent.mkdir()
    shutil.move(str(first.parent), str(moved))
    usd = moved / "bin_condiments.usda"
    stage = Usd.Stage.Open(str(usd))
    assert stage.GetCompositionErrors() == []
    assert validate_stage(usd) == []
    ketchup = stage.GetPrimAtPath("/World/bbq_sauce_bottle")
    assert any(prim.IsA(UsdGeom.Mesh) for prim in Usd.PrimRange(ketchup))  # the asset's meshes came along
    texture = next((moved / ASSETS_FOLDER / "textures").iterdir())
    texture.unlink()
    assert any(texture.name in problem for problem in validate_stage(usd))


def write_asset(path: Path, meters: float = 1.0) -> None:
    """A tiny asset file made elsewhere: one Xform with a cube."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, meters)
    root = UsdGeom.Xform.Define(stage, "/Asset")
    UsdGeom.Cube.Define(stage, "/Asset/Geometry")
    stage.SetDefaultPrim(root.GetPrim())
    stage.GetRootLayer().Save()


def body(stage, path: str, position, yaw_deg: float = 0.0, reference: str | None = None, rigid: bool = False):
    xform = UsdGeom.Xform.Define(stage, path)
    xform.AddTranslateOp().Set(Gf.Vec3d(*position))
    xform.AddRotateZOp().Set(yaw_deg)
    if reference:
        xform.GetPrim().GetReferences().AddReference(reference)
    if rigid:
        UsdPhysics.RigidBodyAPI.Apply(xform.GetPrim())
    return xform.GetPrim()


def foreign_layout(folder: Path, catalog) -> Path:
    """A layout as another tool writes it: centimetres, a table whose top is at 75 cm, bodies under a group prim
    named in its own way (referenced props, a rigid body without a reference, a robot to leave out, a camera), a
    banana inside the bowl at the height where it rests."""
    (folder / "props").mkdir(parents=True)
    for name in ("Banana.usd", "bowl_white.usd", "franka.usd"):
        write_asset(folder / "props" / name, 0.01)
    stage = Usd.Stage.CreateNew(str(folder / "layout.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    world = UsdGeom.Xform.Define(stage, "/Root")
    stage.SetDefaultPrim(world.GetPrim())
    table = UsdGeom.Cube.Define(stage, "/Root/Table")
    table.CreateSizeAttr(1.0)
    table.AddTranslateOp().Set(Gf.Vec3d(55.0, 0.0, 37.5))
    table.AddScaleOp().Set(Gf.Vec3f(90.0, 120.0, 75.0))
    UsdGeom.Xform.Define(stage, "/Root/Props")
    banana_turn = quat_to_matrix(tuple(yaw_quat(math.radians(30.0))))
    banana = placed_pieces(catalog["banana_curved"], banana_turn, np.array([0.5, -0.1, 0.0]))
    rests = drop_height(banana, placed_pieces(catalog["bowl_white"], np.eye(3), np.array([0.5, -0.1, 0.0])))
    body(stage, "/Root/Props/Bowl", (50.0, -10.0, 75.0), reference="./props/bowl_white.usd", rigid=True)
    body(
        stage, "/Root/Props/Banana_01", (50.0, -10.0, 75.0 + 100 * rests), yaw_deg=30.0, reference="./props/Banana.usd"
    )
    body(stage, "/Root/Props/MugA", (40.0, 25.0, 75.0), yaw_deg=-90.0, rigid=True)
    body(stage, "/Root/Robot", (0.0, 0.0, 75.0), reference="./props/franka.usd")
    UsdGeom.Camera.Define(stage, "/Root/Camera")
    stage.GetRootLayer().Save()
    return folder / "layout.usda"


def test_import_of_a_layout_made_elsewhere(tmp_path, catalog):
    """Units, the table top's height, names, a --map file with a pattern and a null, supports from heights."""
    usd = foreign_layout(tmp_path / "elsewhere", catalog)
    mapping = tmp_path / "map.yaml"
    mapping.write_text("props/Banana.usd: banana_curved\nMug*: mug_red\nfranka.usd: null\n")
    report = import_scene(usd, tmp_path / "scene_builders" / "from_elsewhere.yaml", mapping, catalog)
    spec = report.spec
    assert spec.object_names() == ["Bowl", "Banana_01", "MugA"]
    assert [p.asset for p in spec.objects] == ["bowl_white", "banana_curved", "mug_red"]  # map, file stem, pattern
    banana, mug = spec.placement("Banana_01"), spec.placement("MugA")
    assert banana.xy == pytest.approx((0.5, -0.1), abs=1e-12) and mug.xy == pytest.approx((0.4, 0.25), abs=1e-12)
    assert math.degrees(banana.yaw) == pytest.approx(30.0, abs=1e-9) and math.degrees(mug.yaw) == pytest.approx(-90.0)
    assert banana.on == "Bowl" and mug.on is None and spec.placement("Bowl").on is None
    assert any("0.01 m" in note for note in report.notes)
    assert any("/Root/Robot: left out" in note for note in report.notes)


def test_import_of_a_y_up_stage(tmp_path, catalog):
    """A Y-up stage is turned to Z up: its y is the height, its -z the scene's y."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "y_up.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)  # unauthored, USD reads centimetres
    xform = UsdGeom.Xform.Define(stage, "/block_red")
    xform.AddTranslateOp().Set(Gf.Vec3d(0.6, 0.0, -0.2))  # x 0.6, height 0, scene y +0.2
    xform.AddRotateYOp().Set(40.0)  # about the up axis
    UsdPhysics.RigidBodyAPI.Apply(xform.GetPrim())
    stage.GetRootLayer().Save()
    spec = import_scene(tmp_path / "y_up.usda", tmp_path / "y_up.yaml", catalog=catalog).spec
    block = spec.placement("block_red")
    assert block.xy == pytest.approx((0.6, 0.2), abs=1e-12) and math.degrees(block.yaw) == pytest.approx(40.0)
    assert block.tilt == pytest.approx((1.0, 0.0, 0.0, 0.0), abs=1e-12)


def test_unknown_assets_are_named_with_a_fix(tmp_path, catalog):
    """An asset no catalog object matches: the error names the prim, the asset, the closest catalog names and
    --map; a --map entry naming no catalog object names the map file and the key."""
    usd = foreign_layout(tmp_path / "elsewhere", catalog)
    with pytest.raises(RoboLabError) as error:
        import_scene(usd, tmp_path / "out.yaml", catalog=catalog)
    message = str(error.value)
    assert "/Root/Props/Banana_01 (asset ./props/Banana.usd): no catalog object 'Banana'" in message
    assert "Did you mean 'banana'" in message and "--map" in message
    assert "/Root/Robot (asset ./props/franka.usd)" in message and "/Root/Props/MugA" in message
    mapping = tmp_path / "map.yaml"
    mapping.write_text("Banana.usd: bananna_curved\n")
    with pytest.raises(SpecError) as error:
        import_scene(usd, tmp_path / "out.yaml", mapping, catalog)
    assert str(mapping) in str(error.value) and "Banana.usd" in str(error.value) and "banana_curved" in str(error.value)


def test_yaw_and_tilt_give_back_the_rotation():
    """Any rotation splits into the scene file's yaw and tilt turns (x, then y) that give it back; upright and
    one-axis tilts stay in their short form."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        yaw, turns = yaw_and_tilt(quat_to_matrix(tuple(q)))
        tilt = (1.0, 0.0, 0.0, 0.0)
        for axis, deg in turns:
            half = math.radians(deg) / 2
            turn = (math.cos(half), *((math.sin(half), 0.0) if axis == "x" else (0.0, math.sin(half))), 0.0)
            tilt = tuple(quat_multiply(turn, tilt))
            assert -180.0 <= deg <= 180.0
        back = np.array(quat_multiply(yaw_quat(math.radians(yaw)), tilt))
        assert rotation_gap(back, q) < 1e-9
    upright = quat_to_matrix(tuple(yaw_quat(math.radians(33.0))))
    assert yaw_and_tilt(upright) == (33.0, [])
    on_side = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)  # a quarter turn about y
    lying = quat_to_matrix(tuple(quat_multiply(yaw_quat(math.radians(-120.0)), on_side)))
    assert yaw_and_tilt(lying) == (-120.0, [("y", 90.0)])


@pytest.mark.slow
def test_cli_round_trip_loads_lists_and_resets(tmp_path, catalog):
    """From the commands: export a scene with a shelf, move the folder, import it into a content folder; a task on
    it is listed by `robolab list` and its environment resets with the imported bodies, the fixture where the
    source scene puts it."""
    exported = tmp_path / "usd" / "shelf.usda"
    done = subprocess.run(
        [*ROBOLAB, "scene", "export", "mugs_on_shelf", "--usd", str(exported)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "passes USD's checks" in done.stdout
    moved = tmp_path / "moved"
    shutil.move(str(exported.parent), str(moved))
    content = tmp_path / "content"
    scene_file = content / "scene_builders" / "shelf_from_usd.yaml"
    done = subprocess.run(
        [*ROBOLAB, "scene", "import", str(moved / "shelf.usda"), "--out", str(scene_file)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "the scene loader reads it" in done.stdout
    (content / "task_specs").mkdir()
    task = content / "task_specs" / "UsdShelfProbe.yaml"
    task.write_text(
        "name: UsdShelfProbe\nscene: shelf_from_usd\nepisode_seconds: 10\nattributes: []\n"
        "instructions: {default: pick up the white mug, vague: pick it up, specific: pick up the white "
        "mug from the rack}\nsuccess:\n  - {predicate: picked_up, objects: [mug]}\n"
    )
    listed = subprocess.run(
        [*ROBOLAB, "list", "--content", str(content), "--task", "UsdShelfProbe"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert listed.returncode == 0, listed.stderr
    assert "shelf_from_usd" in listed.stdout
    from robolab_ms.envs import RoboLabEnv

    env = RoboLabEnv(task=str(task), obs_mode="state_dict", render_backend="cpu")
    try:
        env.reset(seed=0)
        source = load_scene("mugs_on_shelf")
        assert set(env.objects) == set(source.object_names())
        rack = source.placement("rack_l04")
        pose = env.objects["rack_l04"].pose
        assert np.abs(pose.p[0].cpu().numpy() - [*rack.xy, rack.z]).max() < 1e-5  # a fixture stays where it is put
        mug = env.objects["mug"].pose.p[0].cpu().numpy()
        assert mug[2] > 0.2  # on the rack's middle level, not on the table
    finally:
        env.close()
