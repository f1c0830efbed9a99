"""The subtask state machine, fed condition truth directly (no physics)."""

import torch

from robolab_ms.tasks.progress import Group, ProgressTracker, Stage

GRASP_PLACE = Group((0, 1), (0.0, 1.0))


def step(tracker: ProgressTracker, *rows: list[bool]) -> torch.Tensor:
    score = None
    for row in rows:
        score = tracker.update(torch.tensor([row]))
    return score


def test_jump_ahead_fall_back_and_latch():
    tracker = ProgressTracker([Stage((Group((0, 1, 2), (1.0, 1.0, 2.0)),))], num_envs=1)
    assert step(tracker, [True, False, False]).item() == 0.25
    assert step(tracker, [False, True, False]).item() == 0.5  # jumped to condition 2
    assert step(tracker, [True, False, False]).item() == 0.25  # condition 2 broke: fall back to it
    assert step(tracker, [False, False, False]).item() == 0.0
    assert step(tracker, [False, False, True]).item() == 1.0  # jump straight to the end
    assert step(tracker, [False, False, False]).item() == 1.0  # finished groups stay finished


def test_all_needs_every_group_and_averages():
    tracker = ProgressTracker([Stage((GRASP_PLACE, Group((2, 3), (0.0, 1.0))), "all")], num_envs=1)
    assert step(tracker, [True, True, False, False]).item() == 0.5
    assert step(tracker, [False, False, True, True]).item() == 1.0


def test_any_takes_the_best_group():
    tracker = ProgressTracker([Stage((GRASP_PLACE, Group((2, 3), (0.0, 1.0))), "any")], num_envs=1)
    assert step(tracker, [False, False, False, False]).item() == 0.0  # nothing placed is not progress
    assert step(tracker, [False, False, True, True]).item() == 1.0


def test_choose_k_means_the_best_k():
    groups = tuple(Group((2 * i, 2 * i + 1), (0.0, 1.0)) for i in range(3))
    tracker = ProgressTracker([Stage(groups, "choose", k=2)], num_envs=1)
    assert step(tracker, [False, True, False, False, False, False]).item() == 0.5
    assert step(tracker, [False, True, False, True, False, False]).item() == 1.0


def test_stages_run_in_order_and_batch_independently():
    stages = [Stage((Group((0,), (1.0,)),)), Stage((Group((1,), (1.0,)),))]
    tracker = ProgressTracker(stages, num_envs=2)
    score = tracker.update(torch.tensor([[False, True], [True, False]]))
    assert score.tolist() == [0.0, 0.5]  # env 0: stage 2's condition alone does not count before stage 1
    score = tracker.update(torch.tensor([[True, False], [False, True]]))
    assert score.tolist() == [0.5, 1.0]
    tracker.reset(torch.tensor([1]))
    assert tracker.update(torch.tensor([[False, False], [False, False]])).tolist() == [0.5, 0.0]


def test_groups_of_different_lengths_in_one_stage():
    tracker = ProgressTracker([Stage((GRASP_PLACE, Group((2,), (1.0,))), "all")], num_envs=1)
    assert step(tracker, [True, False, True]).item() == 0.5  # group 1 grasped (weight 0), group 2 done
    assert tracker.stage_index.item() == 0
    assert step(tracker, [False, True, False]).item() == 1.0  # group 2 stays done (latched)
    assert tracker.stage_index.item() == 1


def test_a_steady_scene_gives_a_steady_level():
    """An earlier condition broke while a later one holds: the group stays at the later one, step after step."""
    tracker = ProgressTracker([Stage((Group((0, 1, 2), (1.0, 1.0, 1.0)),))], num_envs=1)
    scores = [step(tracker, [False, True, False]).item() for _ in range(4)]
    assert scores == [scores[0]] * 4 and abs(scores[0] - 2 / 3) < 1e-6
