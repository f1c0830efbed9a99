"""The scene field `rests_on`: an object starts on or in another (RoboLab's stacked Rubik's cubes, its keyboard
leaning into the bin), at the height where it touches its support, and stays there at rest and under jitter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolab_ms.catalog import load_catalog
from robolab_ms.catalog.procedural import quat_multiply, quat_to_matrix, yaw_quat
from robolab_ms.scene import SETTLE_CLEARANCE, footprint, load_scene, read_scene
from robolab_ms.scene.scene_env import SceneOnlyEnv
from robolab_ms.scene.support import drop_height, overlap_depth

CUBE = 0.057  # m, the catalog's rubiks_cube


def box(low, high) -> np.ndarray:
    """The 8 corners of an axis-aligned box."""
    return np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])


def test_drop_height_lowers_an_object_onto_the_highest_surface_below_it():
    floor = box((0, 0, 0), (0.3, 0.3, 0.01))
    wall = box((0.29, 0, 0), (0.3, 0.3, 0.12))
    block = box((0.1, 0.1, 0.5), (0.2, 0.2, 0.6))
    assert drop_height([block], [floor, wall]) == pytest.approx(0.01 - 0.5)  # onto the floor, 49 cm down
    over_the_wall = block + [0.15, 0, 0]
    assert drop_height([over_the_wall], [floor, wall]) == pytest.approx(0.12 - 0.5)  # onto the wall's top
    assert drop_height([block + [1, 0, 0]], [floor, wall]) is None  # beside it: never meets
    # a block leaning at 45 degrees across the wall touches the wall's top edge first
    turn = quat_to_matrix((math.cos(math.pi / 8), 0.0, math.sin(math.pi / 8), 0.0))
    leaning = box((-0.05, 0.1, -0.005), (0.05, 0.2, 0.005)) @ turn.T + [0.295, 0, 0.5]
    lift = drop_height([leaning], [wall])
    lowered = leaning + [0, 0, lift]
    assert overlap_depth([lowered], [wall]) == pytest.approx(0.0, abs=0.002)
    assert overlap_depth([lowered + [0, 0, 0.01]], [wall]) < 0 < overlap_depth([lowered - [0, 0, 0.01]], [wall])


def test_stacked_cubes_start_one_on_another():
    scene = load_scene("mug_banana_ketchup_bowl_rubiks3_bin")
    bottom, middle, top = (scene.placement(f"rubiks_cube_{n}") for n in ("bottom", "middle", "top"))
    assert (bottom.on, middle.on, top.on) == (None, "rubiks_cube_bottom", "rubiks_cube_middle")
    assert scene.supports("rubiks_cube_top") == ["rubiks_cube_middle", "rubiks_cube_bottom"]
    assert scene.base("rubiks_cube_top") == "rubiks_cube_bottom"
    assert middle.z - bottom.z == pytest.approx(CUBE + SETTLE_CLEARANCE, abs=1e-4)
    assert top.z - middle.z == pytest.approx(CUBE + SETTLE_CLEARANCE, abs=1e-4)


def test_a_list_of_tilts_turns_about_fixed_axes_in_order(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(
        "name: s\nobjects:\n  - {asset: rubiks_cube, xy: [0.5, 0.0], tilt: [{axis: x, deg: 30}, {axis: y, deg: 10}]}\n"
    )
    tilt = read_scene(path).objects[0].tilt
    about_x = (math.cos(math.radians(15)), math.sin(math.radians(15)), 0.0, 0.0)
    about_y = (math.cos(math.radians(5)), 0.0, math.sin(math.radians(5)), 0.0)
    assert np.allclose(tilt, quat_multiply(about_y, about_x))


def test_the_keyboard_leans_from_the_bin_floor_over_its_rim():
    scene = load_scene("workdesk_bin")
    catalog = load_catalog()
    keyboard, bin_ = scene.placement("keyboard"), scene.placement("grey_bin")
    assert keyboard.on == "grey_bin"
    rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(keyboard.yaw), keyboard.tilt)))
    points = catalog[keyboard.asset].points @ rotation.T + [*keyboard.xy, keyboard.z]
    floor_top = bin_.z + 0.008  # the bin's floor is 8 mm thick
    assert floor_top <= points[:, 2].min() <= floor_top + 0.006  # its lower end on the floor
    assert points[:, 2].max() > catalog[bin_.asset].dimensions[2] + 0.05  # its upper end well above the rim
    outline = footprint(catalog[bin_.asset], bin_)
    from robolab_ms.scene.outlines import outline_inside

    assert outline_inside(np.array([keyboard.xy]), outline, 0.0)  # its centre over the bin: half in it


@pytest.mark.parametrize("scene_name", ["mug_banana_ketchup_bowl_rubiks3_bin", "workdesk_bin"])
def test_piles_rest_where_they_start_and_jitter_moves_them_whole(scene_name):
    scene = load_scene(scene_name)
    piled = [p.name for p in scene.objects if p.on is not None]
    env = SceneOnlyEnv(scene)
    try:
        for seed in (0, 1):
            env.reset(seed=seed)
            objects = env.builder.objects
            start = {name: actor.pose.p[0].clone() for name, actor in objects.items()}
            for name in piled:  # each piled object keeps its place relative to the base of its pile
                base = scene.placement(scene.base(name))
                layout = np.subtract(scene.placement(name).xy, base.xy)
                now = (start[name] - start[base.name])[:2].numpy()
                assert np.linalg.norm(now) == pytest.approx(np.linalg.norm(layout), abs=1e-4)
            for _ in range(300):  # physics steps, 2.5 s
                env.scene.step()
            drift = {name: float((objects[name].pose.p[0] - start[name]).norm()) for name in piled}
            assert max(drift.values()) < 0.01, drift
    finally:
        env.close()


def test_the_object_pose_variation_moves_a_pile_as_one():
    from robolab_ms.variations.objects import _groups

    scene = load_scene("mug_banana_ketchup_bowl_rubiks3_bin")
    groups = _groups(scene, load_catalog())
    assert ("rubiks_cube_bottom", "rubiks_cube_middle", "rubiks_cube_top") in groups
    assert not any(len(group) == 1 and group[0] in ("rubiks_cube_middle", "rubiks_cube_top") for group in groups)
    groups = _groups(load_scene("workdesk_bin"), load_catalog())
    assert ("grey_bin", "keyboard") in groups
