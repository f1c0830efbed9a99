"""The oracle's handling of a board leaning in a container (world.leaning_board, side_grasps.board_end_grasp,
places.standing_spot, skills.lift_out_standing), on KeyboardOutOfBin's keyboard: 43 cm long, 12.9 cm wide (too
wide for the open fingers), 2.2 cm thick, leaning from the bin's floor over its rim."""

import gymnasium as gym
import numpy as np
import pytest

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy
from robolab_ms.policies.oracle.geometry import quat_to_matrix
from robolab_ms.policies.oracle.gripper import OPEN_FINGER_GAP
from robolab_ms.policies.oracle.places import STAND_MARGIN, standing_spot
from robolab_ms.policies.oracle.side_grasps import BOARD_INSET, board_end_grasp
from robolab_ms.policies.oracle.world import BOARD_LEAN, BOARD_THICKNESS, leaning_board, world_points
from robolab_ms.tasks.spec import load_task


@pytest.fixture
def desk():
    """`desk(seed, task)`: the task (KeyboardOutOfBin unless named) reset at `seed`; closed after the test."""
    made = []

    def make(seed: int, task: str = "KeyboardOutOfBin"):
        env = gym.make(load_task(task).env_id, obs_mode="state_dict")
        made.append(env)
        env.reset(seed=seed)
        env.unwrapped.eval_context.refresh()
        return env.unwrapped

    yield make
    for env in made:
        env.close()


def test_a_keyboard_leaning_in_a_bin_is_a_board_held_at_its_raised_end(desk):
    base = desk(0)
    board = leaning_board(base, "keyboard")
    assert board is not None
    assert board.thickness <= BOARD_THICKNESS < OPEN_FINGER_GAP < board.width < board.length
    assert board.up[2] > np.sin(BOARD_LEAN)
    for lying in ("smartphone", "computer_mouse", "grey_bin"):  # flat on the table, or not thin: no board
        assert leaning_board(base, lying) is None
    grasp = board_end_grasp(base, "keyboard", board)
    rotation = quat_to_matrix(grasp[3:])
    assert np.allclose(rotation[:, 2], -board.up, atol=1e-6)  # pointing down the slope
    assert abs(float(rotation[:, 1] @ board.normal)) == pytest.approx(1.0)  # closing across the thickness
    points = world_points(base, "keyboard")
    along = points @ board.up
    assert float(along.max() - grasp[:3] @ board.up) == pytest.approx(BOARD_INSET, abs=0.003)
    middle = (points.max(axis=0) + points.min(axis=0)) / 2
    assert abs(float((grasp[:3] - middle) @ board.normal)) < 0.005  # between the faces
    assert abs(float((grasp[:3] - middle) @ board.across)) < 0.005  # in the middle of the end


def test_a_tool_leaning_in_a_bin_is_no_board(desk):
    """The hammers leaning in ToolsPickingHammer's bin have heads wider than the open fingers, but their handles
    are narrow: they are held by the handle (`side_grips`), not stood up like a board."""
    base = desk(0, "ToolsPickingHammer")
    for hammer in ("blue_hammer", "husky_hammer", "red_hammer", "wood_hammer"):
        assert leaning_board(base, hammer) is None


@pytest.mark.parametrize("seed", [0, 5])
def test_a_board_stands_outside_its_bin_clear_of_everything_and_is_laid_away_from_it(desk, seed):
    """At seed 5 the gap between the toy and the phone beside the bin is narrower than the keyboard is wide: the
    standing keyboard is turned to fit it."""
    base = desk(seed)
    board = leaning_board(base, "keyboard")
    spot = standing_spot(base, "keyboard", board, [])
    middle = (spot.box[:2] + spot.box[2:]) / 2
    bin_points = world_points(base, "grey_bin")[:, :2]
    low, high = bin_points.min(axis=0), bin_points.max(axis=0)
    assert not np.all((middle >= low) & (middle <= high))
    for other in base.objects:
        if other != "keyboard":
            points = world_points(base, other)[:, :2]
            gaps = np.maximum(points.min(axis=0) - spot.box[2:], spot.box[:2] - points.max(axis=0))
            assert gaps.max() >= STAND_MARGIN - 1e-9, other
    assert float(spot.lay @ (middle - (low + high) / 2)) > 0.0  # laid down away from the bin
    assert (spot.turn != 0.0) == (seed == 5)
    if seed == 0:  # a footprint taken is kept clear of too
        second = standing_spot(base, "keyboard", board, [spot.box])
        gaps = np.maximum(second.box[:2] - spot.box[2:], spot.box[:2] - second.box[2:])
        assert gaps.max() >= STAND_MARGIN - 1e-9


def test_the_oracle_lifts_the_leaning_keyboard_out_and_lays_it_on_the_table(tmp_path):
    config = EvalConfig(tasks=("KeyboardOutOfBin",), episodes=1, first_seed=5)
    results = run_evaluation(make_policy("oracle"), config, tmp_path, show_progress=False)
    assert results[0].error is None and results[0].success
