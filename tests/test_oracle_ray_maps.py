"""The oracle's ray-cast surface maps are kept while nothing in the scene moves and cast again once a body has
moved (an object set elsewhere, the robot's arm turned), on the PredicateLab fixture scene (a bin, a plate, a bowl,
a mug and three blocks)."""

import numpy as np
import pytest
from helpers import FIXTURES

from robolab_ms.policies.oracle.places import PLACE_CELL, map_target
from robolab_ms.policies.oracle.world import RAY_MAPS, cast_surface_grid, surface_grid, world_points


@pytest.fixture(scope="module")
def lab():
    from robolab_ms.envs import RoboLabEnv

    env = RoboLabEnv(task=str(FIXTURES / "PredicateLab.yaml"), obs_mode="none", render_backend="cpu")
    env.reset(seed=0)
    yield env
    env.close()


def bin_map(lab):
    """The map of the bin's floor for setting the green block down in it, cast where it is not kept."""
    points = world_points(lab, "bin")[:, :2]
    middle = (points.min(axis=0) + points.max(axis=0)) / 2
    radius = float(np.max(points.max(axis=0) - middle)) + PLACE_CELL
    return middle, radius


def same_map(one, other) -> bool:
    return np.array_equal(one[0], other[0]) and np.array_equal(one[1], other[1]) and one[2] == other[2]


def test_a_map_is_kept_while_nothing_moves_and_cast_again_when_an_object_moves(lab):
    import sapien

    lab.reset(seed=0)
    lab.eval_context.refresh()
    RAY_MAPS.clear()
    middle, radius = bin_map(lab)
    first = surface_grid(lab, "green", middle, radius, PLACE_CELL)
    assert "red" not in first[2] and "bin" in first[2]
    first[1][:] = -1.0  # what a caller does to its copy leaves the kept map alone
    kept = surface_grid(lab, "green", middle, radius, PLACE_CELL)
    assert len(RAY_MAPS.maps) == 1 and len(next(iter(RAY_MAPS.maps.values()))) == 1
    assert same_map(kept, cast_surface_grid(lab, "green", middle, radius, PLACE_CELL))

    floor = map_target(lab, "green", "bin", beyond=PLACE_CELL)
    spot = floor.cells[floor.flat].mean(axis=0)  # the red block dropped onto the bin's floor
    red = lab.objects["red"]
    red.set_pose(sapien.Pose([float(spot[0]), float(spot[1]), floor.level + 0.03], [1.0, 0.0, 0.0, 0.0]))
    moved = surface_grid(lab, "green", middle, radius, PLACE_CELL)
    assert "red" in moved[2]
    assert same_map(moved, cast_surface_grid(lab, "green", middle, radius, PLACE_CELL))
    assert map_target(lab, "green", "bin", beyond=PLACE_CELL).others.any()


def test_a_map_is_cast_again_when_the_robot_moves(lab):
    lab.reset(seed=0)
    lab.eval_context.refresh()
    RAY_MAPS.clear()
    middle, radius = bin_map(lab)
    surface_grid(lab, "green", middle, radius, PLACE_CELL)
    robot = lab.agent.robot
    qpos = robot.get_qpos().clone()
    qpos[0, 0] += 0.3  # the arm turned at its base
    robot.set_qpos(qpos)
    moved = surface_grid(lab, "green", middle, radius, PLACE_CELL)
    assert len(RAY_MAPS.maps) == 2  # a second scene state, the first one's maps kept beside it
    assert same_map(moved, cast_surface_grid(lab, "green", middle, radius, PLACE_CELL))
