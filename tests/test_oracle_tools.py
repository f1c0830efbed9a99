"""The oracle's holds of heavy tools (policies/oracle: grasps.higher_hold, skills.far_tool) on the drill standing in a bin of ToolsPickingDrill:
held across its body above the battery (its widest part, walled in by the bin), and, where it stands at the edge of
the arm's reach, reached from lower down and drawn nearer before it is lifted out."""

import gymnasium as gym
import numpy as np

from robolab_ms.catalog.procedural import quat_to_matrix
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy
from robolab_ms.policies.oracle.grasps import GRASP_DEPTH, grasp_pose
from robolab_ms.policies.oracle.skills import far_tool
from robolab_ms.policies.oracle.world import world_points
from robolab_ms.tasks.spec import load_task


def test_a_drill_in_a_bin_is_held_across_its_body_above_the_bins_rim():
    env = gym.make(load_task("ToolsPickingDrill").env_id, obs_mode="state_dict")
    try:
        env.reset(seed=0)
        base = env.unwrapped
        grasp = grasp_pose(base, "cordless_drill")
        drill, bin_points = world_points(base, "cordless_drill"), world_points(base, "right_bin")
        length_axis = quat_to_matrix(base.objects["cordless_drill"].pose.raw_pose[0, 3:].cpu().numpy())[:2, 0]
        closing = quat_to_matrix(grasp[3:])[:2, 1]
        assert abs(float(closing @ length_axis)) < np.sin(np.radians(20))  # across the body, not along it
        assert abs(grasp[2] - (drill[:, 2].max() - GRASP_DEPTH)) < 0.005  # under its top, not down at the battery
        assert grasp[2] > bin_points[:, 2].max()  # the fingers stay above the bin's walls
    finally:
        env.close()


def test_a_drill_at_the_edge_of_the_reach_is_drawn_nearer_and_taken_out(tmp_path):
    env = gym.make(load_task("ToolsPickingDrill").env_id, obs_mode="state_dict")
    try:
        env.reset(seed=9)
        assert far_tool(env.unwrapped, "cordless_drill", grasp_pose(env.unwrapped, "cordless_drill"))
    finally:
        env.close()
    config = EvalConfig(tasks=("ToolsPickingDrill",), episodes=1, first_seed=9)
    results = run_evaluation(make_policy("oracle"), config, tmp_path, show_progress=False)
    assert results[0].error is None and results[0].success
