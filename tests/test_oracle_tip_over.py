"""The oracle's turning over of an upside-down object (policies/oracle/skills.py `tip_directions`, `tip_onto_side`),
on the red mug standing upside down in ReorientRedMug's scene: 8.9 cm across, wider than the open fingers, so it is
pushed over onto its side and then stood up."""

import gymnasium as gym
import numpy as np
import pytest

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy
from robolab_ms.policies.oracle.world import world_points
from robolab_ms.tasks.spec import load_task


def test_an_upside_down_mug_is_pushed_over_across_its_handle_onto_free_table():
    from robolab_ms.policies.oracle.skills import TIP_LANDING_MARGIN, tip_directions, upside_down

    env = gym.make(load_task("ReorientRedMug").env_id, obs_mode="state_dict")
    try:
        env.reset(seed=0)
        base = env.unwrapped
        assert upside_down(base, "red_mug") and not upside_down(base, "upright_white_mug")
        directions = tip_directions(base, "red_mug")
        assert directions, "the mug has room to fall onto its side"
        mug = world_points(base, "red_mug")
        flat = mug[:, :2] - mug[:, :2].mean(axis=0)
        handle = np.linalg.svd(flat, full_matrices=False)[2][0]  # the long axis: from the body out to the handle
        height = float(np.ptp(mug[:, 2]))
        for direction in directions:
            assert direction[2] == 0.0 and np.linalg.norm(direction) == pytest.approx(1.0)
            assert abs(float(direction[:2] @ handle)) < np.sin(np.radians(41))  # across the handle, not over it
            across = np.array([-direction[1], direction[0]])
            far = float((flat @ direction[:2]).max())
            for other in base.objects:  # nothing low stands on the side it falls onto
                if other == "red_mug":
                    continue
                points = world_points(base, other)
                rel = points[points[:, 2] < height, :2] - mug[:, :2].mean(axis=0)
                beyond = rel @ direction[:2] - far
                inside = (beyond > -TIP_LANDING_MARGIN) & (beyond < height + TIP_LANDING_MARGIN)
                inside &= np.abs(rel @ across) < float(np.abs(flat @ across).max()) + TIP_LANDING_MARGIN
                assert not inside.any(), f"{other} stands where the mug would fall"
    finally:
        env.close()


@pytest.mark.slow
def test_the_oracle_turns_an_upside_down_mug_upright(tmp_path):
    config = EvalConfig(tasks=("ReorientRedMug",), episodes=1, first_seed=0)
    results = run_evaluation(make_policy("oracle"), config, tmp_path, show_progress=False)
    assert results[0].error is None and results[0].success
