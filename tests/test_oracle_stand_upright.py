"""The oracle's `stand_upright` skill (policies/oracle/skills.py) on the white coffee mug lying on its side in
ReorientWhiteMugs' scene: held by the top of its rim and tipped up about its base. The arm lags its commands, so the
skill's plan waits for it twice: outside the opening before the hand moves straight in (a corner cut brings the
fingers down on the rim and pushes the mug away), and at the end of the turn before the fingers open (let go
early, the mug stood half-way and fell back onto its side)."""

import gymnasium as gym
import numpy as np
import pytest

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy
from robolab_ms.tasks.spec import load_task


def _runs(actions: list[np.ndarray]) -> list[tuple[np.ndarray, int]]:
    """The queued actions as (action, how many times in a row)."""
    runs: list[tuple[np.ndarray, int]] = []
    for action in actions:
        if runs and np.array_equal(runs[-1][0], action):
            runs[-1] = (action, runs[-1][1] + 1)
        else:
            runs.append((action, 1))
    return runs


def test_the_plan_waits_outside_the_opening_and_at_the_end_of_the_turn():
    from robolab_ms.policies.oracle.motion import SETTLE_STEPS, MotionPlanner, seed_planner
    from robolab_ms.policies.oracle.skills import PIVOT_HOLD_STEPS, STEP_SETTLE_STEPS, stand_upright

    env = gym.make(load_task("ReorientWhiteMugs").env_id, obs_mode="state_dict")
    try:
        env.reset(seed=0)
        lab = env.unwrapped
        lab.eval_context.refresh()
        seed_planner(0)
        motion = MotionPlanner(lab)
        motion.bind(lab)
        motion.sync_fixtures()
        stand_upright(motion, "sideways_white_mug")
        runs = _runs(list(motion.actions))
        closed = [i for i, (action, _) in enumerate(runs) if action[7] == 1.0]
        assert closed, "the hand closes on the rim"
        # the last closed posture is held until the arm has finished the turn, then the same posture opens
        end, held = runs[closed[-1]]
        assert held >= PIVOT_HOLD_STEPS + SETTLE_STEPS
        following = runs[closed[-1] + 1][0]
        assert following[7] == 0.0 and np.array_equal(following[:7], end[:7])
        # before the straight move in, the open hand holds still outside the opening
        waits = [count for action, count in runs[: closed[0]] if action[7] == 0.0]
        assert max(waits) >= STEP_SETTLE_STEPS + SETTLE_STEPS
    finally:
        env.close()


@pytest.mark.slow
def test_the_oracle_stands_the_lying_white_mug(tmp_path):
    """Seed 2: the first tip let go with the mug half-way up; it fell back and every later grasp missed the rim,
    until the episode ran out of time."""
    config = EvalConfig(tasks=("ReorientWhiteMugs",), episodes=1, first_seed=2)
    results = run_evaluation(make_policy("oracle"), config, tmp_path, show_progress=False)
    assert results[0].error is None and results[0].success
