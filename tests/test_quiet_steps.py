"""Quiet steps: when nothing moved, evaluate() reuses the last result; it must be exactly what a full evaluation
would give, and anything that moves an object must end the reuse."""

import torch
from helpers import hold_arm_action, put

REPORTED = ("success", "score", "progress", "stage")


def settle(env, max_steps: int = 200) -> None:
    """Hold the arm until the task logic starts reusing results (every object asleep)."""
    evaluator = env.task_evaluator
    action = hold_arm_action(env, 0.0)
    for _ in range(max_steps):
        before = evaluator.quiet_steps
        env.step(action)
        if evaluator.quiet_steps > before:
            return
    raise AssertionError(f"no quiet step within {max_steps} steps: objects never fell asleep")


def test_quiet_result_equals_a_full_evaluation(lab):
    settle(lab)
    quiet = lab.evaluate()
    full = lab.task_evaluator._evaluate_in_full(lab.gripper_closed_fraction())
    for key in REPORTED:
        assert torch.equal(quiet[key], full[key]), key
    assert not any(bool(flag.any()) for key, flag in quiet.items() if key.startswith("event_"))


def test_moving_an_object_ends_the_reuse(lab):
    settle(lab)
    assert not bool(lab.evaluate()["success"])
    put(lab, "red", (0.45, 0.28, 0.06))  # dropped into the bin: the block wakes up and the task logic sees it
    action = hold_arm_action(lab, 0.0)
    quiet_before = lab.task_evaluator.quiet_steps
    _, _, _, _, info = lab.step(action)
    assert lab.task_evaluator.quiet_steps == quiet_before
    for _ in range(30):
        _, _, _, _, info = lab.step(action)
    assert bool(info["success"])


def _quiet_while_closing(env) -> int:
    """Close the gripper in the air with the arm held: how many of those steps reused the last result."""
    settle(env)
    before = env.task_evaluator.quiet_steps
    action = hold_arm_action(env, 1.0)
    for _ in range(20):
        env.step(action)
    return env.task_evaluator.quiet_steps - before


def test_the_gripper_closing_ends_the_reuse_only_where_events_are_tracked(lab):
    lab.task_evaluator.track_events = False  # as in `robolab validate`'s random episodes
    assert _quiet_while_closing(lab) == 20
    lab.task_evaluator.track_events = True
    for _ in range(20):
        lab.step(hold_arm_action(lab, 0.0))  # open again
    assert _quiet_while_closing(lab) < 20  # its closed fraction crosses the event thresholds
