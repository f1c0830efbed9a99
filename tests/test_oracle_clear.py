"""The oracle beside a shelf (policies/oracle/motion.py): the hand is checked against the rack as the real
gripper, a mug is held by the side of its wall away from the rack, and a bowl beside the rack goes onto its top."""

import numpy as np
import pytest
from helpers import oracle_at_reset

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy
from robolab_ms.policies.oracle.grasps import grasp_pose
from robolab_ms.policies.oracle.world import centre


def test_beside_the_rack_the_hand_is_the_gripper_and_the_mug_is_held_away_from_it():
    with oracle_at_reset("PutMugsOnShelf", 7) as (base, oracle):
        home = oracle.motion.current_qpos()
        touching = {hit.link_name1 for hit in oracle.motion.planner.check_for_env_collision(qpos=home)}
        assert touching == set()  # the planner's hand is the droid's gripper: at the start posture, where the Panda
        assert not oracle.motion.collides(home)  # hand of ManiSkill's arm model reaches the top board, it does not
        mug, rack = centre(base, "mug")[:2], centre(base, "rack_l04")[:2]
        grasp = grasp_pose(base, "mug")
        towards_rack = float((grasp[:2] - mug) @ (rack - mug)) / float(np.linalg.norm(rack - mug))
        assert towards_rack < 0.005  # a wall on the far side from the rack or across it, never the wall facing it


@pytest.mark.slow
def test_oracle_puts_a_bowl_beside_the_rack_on_its_top(tmp_path):
    """Seed 5: the descent the planner picks first passes the forearm through the rack's top board; the fallback
    joint path used to push the bowl aside before the grasp."""
    results = run_evaluation(
        make_policy("oracle"),
        EvalConfig(tasks=("PutBowlOnShelfTop",), episodes=1, first_seed=5),
        tmp_path,
        show_progress=False,
    )
    assert results[0].error is None and results[0].success
