"""The oracle's side hold of a long tool packed among others in a bin (policies/oracle/side_grasps.py), on the hammers
lying side by side, millimetres apart, in the left bin of ToolsPickingHammer: held by the part of the handle that
reaches out over the bin's wall, the hand level and on the handle's free side, the fingers closing vertically."""

import gymnasium as gym
import numpy as np

from robolab_ms.catalog.procedural import quat_to_matrix
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy
from robolab_ms.policies.oracle.side_grasps import side_grips
from robolab_ms.policies.oracle.world import world_points
from robolab_ms.tasks.spec import load_task


def test_a_packed_hammer_is_held_by_its_handle_from_its_free_side_outside_the_bin():
    env = gym.make(load_task("ToolsPickingHammer").env_id, obs_mode="state_dict")
    try:
        env.reset(seed=0)
        base = env.unwrapped
        grips = side_grips(base, "blue_hammer")
        assert grips, "the hammer packed among the others has a side hold"
        grasp, approach = grips[0]
        rotation = quat_to_matrix(grasp[3:])
        assert abs(rotation[2, 1]) > np.cos(np.radians(30))  # the fingers close up and down, across the handle
        assert abs(approach[2]) < 1e-6 and np.allclose(rotation[:, 2], approach, atol=1e-6)  # in level from a side
        bin_points = world_points(base, "left_bin")
        low, high = bin_points[:, :2].min(axis=0), bin_points[:, :2].max(axis=0)
        assert not np.all((grasp[:2] >= low) & (grasp[:2] <= high))  # on the handle where it is out of the bin
        for other in ("husky_hammer", "red_hammer", "wood_hammer"):  # the hand comes from the side none lies on
            rel = world_points(base, other)[:, :2] - grasp[:2]
            assert np.all(rel @ -approach[:2] < 0.005)
        assert side_grips(base, "left_bin") == []  # no handle: no side hold
    finally:
        env.close()


def test_the_oracle_takes_a_packed_hammer_out_of_its_bin(tmp_path):
    config = EvalConfig(tasks=("ToolsPickingHammer",), episodes=1, first_seed=1)
    results = run_evaluation(make_policy("oracle"), config, tmp_path, show_progress=False)
    assert results[0].error is None and results[0].success
