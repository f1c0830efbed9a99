"""The oracle's clear descent: a top-down grasp next to a fixture (a shelf) reached in an arm posture from which the
hand can come straight down.

Inverse kinematics picks the posture above a grasp nearest the arm's current one; beside a shelf, the forearm of
that posture can pass through the shelf's boards or legs on the way down, so the straight descent cannot be
planned and the fallback joint path swings the open fingers through the object (a bowl pushed aside and then
grasped tilted, slipping out on the way up). Where that happens, the postures above the grasp that inverse
kinematics finds from many random starts are tried in turn, and the hand goes to the first one from which the
straight descent is free of the fixtures.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import TYPE_CHECKING, Iterator

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.policies.oracle import OraclePolicy

PLANNER_HAND_LINKS = ("panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_hand_tcp")  # the planner's
# Panda hand, wider than the droid's gripper (its fingers' outer faces 5 cm from the TCP, its body 6 cm): against the
# fixtures the hand is checked as the oracle's own solids of the real gripper instead (HAND_SOLIDS)
POSTURE_STARTS = 200  # random starts of inverse kinematics when looking for a posture with a clear descent
NEUTRAL_POSTURE = (0.0, np.pi / 8, 0.0, -5 * np.pi / 8, 0.0, 3 * np.pi / 4, np.pi / 4)  # the Panda's rest joints
FIXTURE_MARGIN = 0.02  # m the fixtures grow by while a posture and the way down from it are chosen (the arm lags
# its targets by a centimetre or two on a fast descent)
FIXTURE_CLEARANCE = 0.12  # m (horizontally) from a fixture's piece above it within which a grasp's arm comes close
LOWER_STEP = 0.05  # m between the lower heights over the grasp tried where no posture at the planned one has one


def arm_hits_fixture(policy: OraclePolicy, qpos: np.ndarray) -> bool:
    """Whether the arm at planning-model joints `qpos` hits a fixture: its links from the flange back as the
    planner models them, the hand as the real gripper's solids at the TCP (`_hand_clear`)."""
    from robolab_ms.policies.oracle import FLANGE_LINK, _fixture_boxes, _hand_clear

    planner = policy._planner
    if any(hit.link_name1 not in PLANNER_HAND_LINKS for hit in planner.check_for_env_collision(qpos=qpos)):
        return True
    boxes = getattr(policy, "_fixture_box_cache", None)
    if boxes is None or boxes[0] is not policy.env or boxes[1] != policy._fixture_names:
        policy._fixture_box_cache = boxes = (policy.env, list(policy._fixture_names), _fixture_boxes(policy.env))
    model = planner.pinocchio_model
    model.compute_forward_kinematics(qpos)
    flange = np.asarray(model.get_link_pose(planner.link_name_2_idx[FLANGE_LINK]))
    import sapien

    tcp = sapien.Pose(p=flange[:3], q=flange[3:]) * policy._tcp_in_flange
    return not _hand_clear(np.concatenate([tcp.p, tcp.q]), boxes[2])


def fixture_closeness(boxes: list[tuple[np.ndarray, np.ndarray, np.ndarray]], xy: np.ndarray, z: float) -> float:
    """How far (m) a top-down grasp at (`xy`, `z`) is inside FIXTURE_CLEARANCE of the nearest of the fixture
    `boxes` that reaches above it (a shelf's board or leg beside it, not the board it stands on): 0 where none is
    that near. The descending arm passes such a piece within centimetres, so the side of a wide container away
    from it is the better one to hold."""
    worst = 0.0
    for rotation, centre, half in boxes:
        if float(centre[2] + np.abs(rotation[2]) @ half) <= z + 0.05:
            continue
        local = np.abs((np.array([xy[0], xy[1], centre[2]]) - centre) @ rotation)[:2]
        outside = np.maximum(local - half[:2], 0.0)  # (boxes of the fixtures stand upright: x, y span the floor)
        worst = max(worst, FIXTURE_CLEARANCE - float(np.linalg.norm(outside)))
    return worst


@contextmanager
def _inflated_fixtures(policy: OraclePolicy, margin: float) -> Iterator[None]:
    """The planner's fixture boxes grown by `margin` on every side for the duration, the exact ones after."""
    import mplib.pymp as mp

    from robolab_ms.policies.oracle import _fixture_boxes, _matrix_to_quaternion

    fcl = mp.collision_detection.fcl
    boxes = _fixture_boxes(policy.env) if policy._fixture_names else []

    def install(grow: float) -> None:
        for name, (rotation, centre, half) in zip(policy._fixture_names, boxes):
            shape = fcl.CollisionObject(fcl.Box(2 * (half + grow)), centre, _matrix_to_quaternion(rotation))
            policy._planner.set_normal_object(name, shape)

    install(margin)
    try:
        yield
    finally:
        install(0.0)


def clear_posture(policy: OraclePolicy, qpos: np.ndarray, above: np.ndarray, target: np.ndarray) -> np.ndarray | None:
    """A posture (planning-model joints) with the TCP at pose `above` from which a straight move to TCP pose
    `target` is planned free of the fixtures, nearest in joint space to the arm's neutral posture turned towards
    `target` (not to `qpos`, which after a place on a high shelf may be a flipped one); None where there is none."""
    planner = policy._planner
    status, goals = planner.IK(policy._flange_target(above), qpos, n_init_qpos=POSTURE_STARTS)
    if status != "Success":
        return None
    goal_flange = policy._flange_target(target)
    neutral = np.array(NEUTRAL_POSTURE)
    neutral[0] = np.arctan2(target[1], target[0])  # the shoulder turned towards the grasp
    for goal in sorted(goals, key=lambda joints: float(np.abs(joints[:7] - neutral).max())):
        start = qpos.copy()
        start[:7] = goal[:7]
        if policy._collides(start):
            continue
        if policy._plan_straight(goal_flange, start)["status"] == "Success":
            return start
    return None


def _clears_below(policy: OraclePolicy, pose: np.ndarray, target: np.ndarray) -> bool:
    """Whether TCP pose `pose` is at least APPROACH_HEIGHT above `target` and its fingertips TRAVEL_CLEARANCE above
    every object within TRAVEL_RADIUS that rises from below it (the fixtures aside, which the planner keeps the arm
    out of, and what stands on their levels above the hand)."""
    from robolab_ms.policies.oracle import (
        APPROACH_HEIGHT,
        FINGERTIP_BELOW_TCP,
        TRAVEL_CLEARANCE,
        TRAVEL_RADIUS,
        _world_points,
    )

    if pose[2] < target[2] + APPROACH_HEIGHT - 1e-6:
        return False
    env = policy.env
    env.eval_context.refresh()
    for name in env.objects:
        if env.eval_context.entries[name].is_fixture:
            continue
        points = _world_points(env, name)
        if points[:, 2].min() > pose[2]:
            continue
        near = np.linalg.norm(points[:, :2] - pose[:2], axis=1) < TRAVEL_RADIUS
        if float(points[near, 2].max(initial=0.0)) + TRAVEL_CLEARANCE + FINGERTIP_BELOW_TCP > pose[2]:
            return False
    return True


def _free_joint_line(policy: OraclePolicy, qpos: np.ndarray, goal: np.ndarray) -> np.ndarray | None:
    """A timed joint path along the straight line in joint space from `qpos` to `goal`, free of self-collision and
    of the fixtures once the arm has left a collision it starts in (the planner's hand model is wider than the
    gripper and may touch a shelf at the start); None where it is not free."""
    from robolab_ms.policies.oracle import JOINT_PATH_RESOLUTION

    count = int(np.ceil(np.max(np.abs(goal[:7] - qpos[:7])) / JOINT_PATH_RESOLUTION)) + 1
    path = np.linspace(qpos, goal, max(count, 2))
    leaving = True
    for point in path[1:]:
        hit = policy._collides(point)
        if hit and not leaving:
            return None
        leaving = leaving and hit
    if leaving:
        return None
    _, position, *_ = policy._planner.TOPP(path[:, :7], policy._time_step)
    return position


def reach_over_clear(
    policy: OraclePolicy, qpos: np.ndarray, above: np.ndarray, target: np.ndarray, name: str
) -> np.ndarray:
    """Queue the move from posture `qpos` to TCP pose `above` over object `name` (`OraclePolicy._reach_over`);
    where fixtures are in the scene and the straight move from there down to `target` cannot be planned, the move
    goes instead to a posture from which it can (`clear_posture`), if there is one; where `above` cannot be reached
    at all, to such a posture lower down (`_clear_approach`). Returns the final joints."""
    from robolab_ms.policies.oracle import OracleFailure

    planned = len(policy.actions)
    try:
        end = policy._reach_over(qpos, above, name)
    except OracleFailure as error:  # `above` out of reach (raised high over a tall neighbour): lower, if it clears
        failure, end = error, None
    if end is not None and not policy._fixture_names:
        return end
    if end is not None and policy._plan_straight(policy._flange_target(target), end)["status"] == "Success":
        return end
    with _inflated_fixtures(policy, FIXTURE_MARGIN):
        path = _clear_approach(policy, qpos, above, target)
    if path is None:
        if end is None:
            raise failure
        return end
    while len(policy.actions) > planned:
        policy.actions.pop()
    return policy._queue(qpos, path)


def _clear_approach(policy: OraclePolicy, qpos: np.ndarray, above: np.ndarray, target: np.ndarray) -> np.ndarray | None:
    """A timed joint path from `qpos` to a posture over `target` from which the straight move down to it is free
    (`clear_posture`): at the height of `above`, else at lower heights from which the fingertips still clear the
    objects around (`_clears_below`); None where there is none."""
    goal = clear_posture(policy, qpos, above, target)
    if goal is not None:
        result = policy._plan_to_joints([goal], qpos)
        if result["status"] == "Success":
            return result["position"]
    for height in np.arange(above[2] - LOWER_STEP, target[2], -LOWER_STEP):  # beside a tall shelf: come in lower
        lowered = above.copy()
        lowered[2] = height
        if not _clears_below(policy, lowered, target):
            continue
        goal = clear_posture(policy, qpos, lowered, target)
        path = _free_joint_line(policy, qpos, goal) if goal is not None else None
        if path is not None:
            return path
    return None


def move_for_chain(
    policy: OraclePolicy, qpos: np.ndarray, pose: np.ndarray, chain: list[np.ndarray], what: str
) -> np.ndarray:
    """Queue the move from posture `qpos` to TCP pose `pose` (`OraclePolicy._move`, a sampled path allowed) so that
    it ends in a posture from which the straight moves through the TCP poses `chain` can be planned: where the
    posture it reaches has none, the postures over `pose` found from many random starts are tried (nearest the
    arm's rest posture turned towards `pose` first). Returns the final joints."""
    planned = len(policy.actions)
    end = policy._move(qpos, pose, what, straight=False)
    if policy._straight_chain(end, chain) is not None:
        return end
    status, goals = policy._planner.IK(policy._flange_target(pose), qpos, n_init_qpos=POSTURE_STARTS)
    if status != "Success":
        return end
    neutral = np.array(NEUTRAL_POSTURE)
    neutral[0] = np.arctan2(pose[1], pose[0])
    for goal in sorted(goals, key=lambda joints: float(np.abs(joints[:7] - neutral).max())):
        start = qpos.copy()
        start[:7] = goal[:7]
        if policy._collides(start) or policy._straight_chain(start, chain) is None:
            continue
        result = policy._plan_to_joints([start], qpos)
        if result["status"] != "Success":
            continue
        while len(policy.actions) > planned:
            policy.actions.pop()
        return policy._queue(qpos, result["position"])
    return end
