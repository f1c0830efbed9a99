"""The side hold's lift (policies/oracle/skills.py): the angle a tool held by its handle hangs at as the grip rises
(`swing_angle`), and, on ToolsPickingHammer's packed hammers, the hand that turns with the swinging hammer so that
it is carried hanging from the pads and laid on the table."""

import gymnasium as gym
import numpy as np
import pytest

from robolab_ms.policies.oracle.skills import swing_angle

REACH, SLOPE, START = 0.25, np.radians(35.0), 0.16  # a hammer's head a quarter metre from the grip, 35 degrees down
FLOOR = START - REACH * np.sin(SLOPE)


def _angle(height, wall=0.0, rim=0.15, depth=0.0):
    return swing_angle(height, START, REACH, SLOPE, depth, wall, rim)


def test_the_far_end_slides_along_the_floor_under_the_rising_grip():
    assert _angle(START) == pytest.approx(SLOPE)
    assert _angle(START + 0.03) == pytest.approx(np.arcsin((START + 0.03 - FLOOR) / REACH))
    heights = np.linspace(START, START + 0.2, 21)
    angles = [_angle(height) for height in heights]
    assert all(later >= earlier for earlier, later in zip(angles, angles[1:]))  # it only swings further down


def test_the_near_wall_holds_the_far_end_back_until_it_is_above_the_rim():
    wall = 0.05  # the container's near wall this far out from the grip
    held_back = np.arccos(wall / REACH)
    assert _angle(START + 0.12, wall=wall) == pytest.approx(held_back)  # free, it would hang straight down
    over = FLOOR + REACH * np.sin(held_back) + 0.16  # the far end's lowest point just above the rim
    assert _angle(over, wall=wall, rim=0.15) == pytest.approx(np.pi / 2)  # past the rim: straight down
    assert _angle(over, wall=wall, rim=0.15, depth=0.05) == pytest.approx(held_back)  # a deeper end is still in


@pytest.mark.slow
def test_a_hammer_held_from_the_side_hangs_from_the_pads_and_is_laid_on_the_table():
    """Planned with the side hold alone, the blue hammer rises out of the bin hanging head down, the fingers still
    closing across its handle, and ends lying on the table outside the bin."""
    from robolab_ms.policies.oracle import OraclePolicy
    from robolab_ms.policies.oracle.geometry import quat_to_matrix
    from robolab_ms.policies.oracle.side_grasps import side_grips
    from robolab_ms.policies.oracle.skills import side_hold_pick_and_place
    from robolab_ms.policies.oracle.world import world_points
    from robolab_ms.tasks.spec import load_task

    env = gym.make(load_task("ToolsPickingHammer").env_id, obs_mode="state_dict")
    try:
        env.reset(seed=1)
        base = env.unwrapped
        oracle = OraclePolicy()
        oracle.bind(env)
        oracle.reset("", env.action_space, seed=1)
        job = next(job for job in oracle.compiled if job.obj == "blue_hammer")
        side_hold_pick_and_place(oracle.motion, "blue_hammer", side_grips(base, "blue_hammer"), [], at=job.at)
        highest, hanging = -1.0, None
        while oracle.motion.actions:
            action = oracle.motion.actions.popleft()
            env.step(action)
            tcp = base.tcp_pose()
            height = float(tcp.p[0, 2])
            if action[7] > 0.5 and height > highest:  # the highest the hand holding the hammer goes
                highest = height
                points = world_points(base, "blue_hammer")
                closing = quat_to_matrix(tcp.q[0].cpu().numpy())[:, 1]
                hanging = (points[:, 2].min(), tcp.p[0].cpu().numpy(), closing)
        for _ in range(40):  # let go: it falls the last few degrees flat
            env.step(oracle.motion.action(oracle.motion.current_qpos(), 0.0))
        lowest, top, closing = hanging
        assert top[2] - lowest > 0.2  # the whole hammer hangs below the hand at the top of the lift
        assert abs(closing[2]) < np.sin(np.radians(30.0))  # the pads close level, across the hanging handle
        env.unwrapped.eval_context.refresh()
        points = world_points(base, "blue_hammer")
        bin_points = world_points(base, "left_bin")
        assert points[:, 2].min() < 0.01 and points[:, 2].max() < 0.15  # on the table, lying (it is 33 cm long)
        low, high = bin_points[:, :2].min(axis=0), bin_points[:, :2].max(axis=0)
        middle = points[:, :2].mean(axis=0)
        assert not np.all((middle >= low) & (middle <= high))  # outside the bin
    finally:
        env.close()


def test_a_side_hold_may_start_along_the_handle_beyond_its_free_end(monkeypatch):
    """The hand starts a side hold level across the handle first, nearest first; last, on the handle's line
    beyond its free end with the hand turned as it holds, so that the open fingers slide on along the handle
    (where the arm cannot point across it from further out)."""
    from robolab_ms.policies.oracle import skills

    end, direction = np.array([0.45, 0.3, 0.2]), np.array([np.cos(0.35), 0.0, -np.sin(0.35)])  # sloping into a bin
    monkeypatch.setattr(skills, "handle_part", lambda env, name: (end, direction, 0.12, 0.015))
    grasp = np.concatenate([end + direction * 0.08, [1.0, 0.0, 0.0, 0.0]])
    approach = np.array([0.0, -1.0, 0.0])
    starts = skills._side_hold_starts(None, "hammer", grasp, approach)
    assert len(starts) == len(skills.SIDE_APPROACHES) + 1
    for start, distance in zip(starts, skills.SIDE_APPROACHES):
        assert np.allclose(start[:3], grasp[:3] - approach * distance)
    slide = starts[-1]
    assert np.allclose(slide[3:], grasp[3:])  # the hand as it holds
    offset = slide[:3] - end
    assert np.allclose(offset, -direction * skills.SIDE_SLIDE_PAST)  # on the handle's line, past its free end
    monkeypatch.setattr(skills, "handle_part", lambda env, name: None)
    assert len(skills._side_hold_starts(None, "hammer", grasp, approach)) == len(skills.SIDE_APPROACHES)
