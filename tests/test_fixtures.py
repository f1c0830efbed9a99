"""Fixtures: catalog objects marked `fixture` (shelves, racks) are built kinematic where the scene file puts them,
never jittered or pushed away, and other objects stand on their levels (scene fields `rests_on` + `level`)."""

from __future__ import annotations

import pytest
import torch

from robolab_ms.catalog import load_catalog
from robolab_ms.errors import SpecError
from robolab_ms.scene import SETTLE_CLEARANCE, load_scene, read_scene
from robolab_ms.scene.scene_env import SceneOnlyEnv

RACK_LEVELS = (0.015, 0.2475, 0.48)  # board tops of the catalog's rack_wooden (m)


def test_a_rack_is_a_fixture_with_three_levels():
    rack = load_catalog()["rack_wooden"]
    assert rack.is_fixture and not load_catalog()["mug_white"].is_fixture
    assert rack.levels == pytest.approx(RACK_LEVELS)


def test_objects_stand_on_the_level_they_name():
    scene = load_scene("mugs_on_shelf")
    rack, mug = scene.placement("rack_l04"), scene.placement("mug")
    assert rack.fixture and rack.z == 0.0
    assert (mug.on, mug.level) == ("rack_l04", 1)
    bottom = load_catalog()[mug.asset].bounds[0, 2]  # its collision's lowest point (a mesh's may be below 0)
    assert mug.z == pytest.approx(RACK_LEVELS[1] + SETTLE_CLEARANCE - bottom, abs=1e-4)
    assert scene.base("mug") == "mug"  # jittered on its own: the rack under it stays


def scene_file(tmp_path, *lines: str):
    path = tmp_path / "shelf_test.yaml"
    path.write_text(
        "name: shelf_test\nobjects:\n  - {name: rack, asset: rack_wooden, xy: [0.5, 0.0]}\n"
        + "".join(f"  - {line}\n" for line in lines)
    )
    return path


@pytest.mark.parametrize(
    "line, field, words",
    [
        ("{asset: mug_white, xy: [0.5, 0.0], rests_on: rack}", "level", "has 3 levels"),
        ("{asset: mug_white, xy: [0.5, 0.0], rests_on: rack, level: 3}", "level", "not a level"),
        ("{asset: mug_white, xy: [0.3, 0.0], level: 1}", "level", "does not rest on a fixture"),
        ("{asset: mug_white, xy: [0.5, 0.3], rests_on: rack, level: 1}", "xy", "not over"),
        ("{asset: utility_jug_tall, xy: [0.5, 0.0], rests_on: rack, level: 1}", "xy", "into the fixture"),
        ("{asset: mug_white, xy: [0.5, 0.135], rests_on: rack, level: 1}", "xy", "into the fixture"),
    ],
)
def test_bad_levels_are_refused_with_the_field_and_a_fix(tmp_path, line, field, words):
    with pytest.raises(SpecError) as error:
        read_scene(scene_file(tmp_path, line))
    assert f"objects[1].{field}" in str(error.value) and words in str(error.value)


def test_a_fixture_stands_on_the_table(tmp_path):
    path = tmp_path / "shelf_test.yaml"
    path.write_text(
        "name: shelf_test\nobjects:\n  - {name: box, asset: cube_box_cardboard, xy: [0.5, 0.0]}\n"
        "  - {name: rack, asset: rack_wooden, xy: [0.5, 0.0], rests_on: box}\n"
    )
    with pytest.raises(SpecError, match=r"objects\[1\]\.rests_on.*fixture"):
        read_scene(path)


def test_the_pose_variation_leaves_fixtures_and_what_stands_on_them():
    from robolab_ms.variations.objects import _groups

    groups = _groups(load_scene("mugs_on_shelf"), load_catalog())
    assert sorted(groups) == [("serving_bowl",), ("utilityjug_a01",)]


def test_objects_rest_on_a_level_and_the_rack_stays_put_when_hit():
    scene = load_scene("mugs_on_shelf")
    env = SceneOnlyEnv(scene)
    try:
        places = []
        for seed in (0, 1):
            env.reset(seed=seed)
            objects = env.builder.objects
            rack = objects["rack_l04"]
            start = {name: actor.pose.p[0].clone() for name, actor in objects.items()}
            places.append(start["mug"])
            assert torch.allclose(start["rack_l04"], torch.tensor([0.5087, 0.0246, 0.0]), atol=1e-6)  # no jitter
            for _ in range(300):  # physics steps, 2.5 s at rest
                env.scene.step()
            for name in ("mug", "ceramic_mug"):
                assert float((objects[name].pose.p[0] - start[name]).norm()) < 0.02, name
                assert float(objects[name].pose.p[0, 2]) == pytest.approx(
                    RACK_LEVELS[1], abs=0.005
                )  # on the middle level
        assert float((places[0] - places[1]).norm()) > 1e-3  # the jitter moves the mugs on the rack
        # the jug, thrown at the rack's post at 2 m/s, bounces off it; the rack does not move
        jug = objects["utilityjug_a01"]
        jug.set_pose(type(jug.pose).create_from_pq(torch.tensor([[0.36, -0.15, 0.1]]), torch.tensor([[1.0, 0, 0, 0]])))
        jug.set_linear_velocity(torch.tensor([[2.0, 0.0, 0.0]]))
        rack_pose = rack.pose.raw_pose.clone()
        for _ in range(120):
            env.scene.step()
        assert torch.equal(rack.pose.raw_pose, rack_pose)
        assert float(jug.pose.p[0, 0]) < 0.45  # stopped at the post (x 0.419..0.439), not through it
        # a mug dropped onto the top board stays on it
        mug = objects["mug"]
        mug.set_pose(type(mug.pose).create_from_pq(torch.tensor([[0.51, 0.02, 0.55]]), torch.tensor([[1.0, 0, 0, 0]])))
        for _ in range(240):
            env.scene.step()
        assert float(mug.pose.p[0, 2]) == pytest.approx(RACK_LEVELS[2], abs=0.005)
    finally:
        env.close()
