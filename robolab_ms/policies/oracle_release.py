"""Where the oracle releases an object in a bin too large for the arm to reach its middle.

The free spot farthest from the robot that the held object reaches over the rim is at the edge of the arm's reach:
there the arm takes odd postures, a wide hand drifts into the bin's far wall on the way down, and the joint-space
move to the next object sweeps the arm through the wall. The object is set down a few centimetres nearer the robot
instead, as long as that still leaves room beside it for another object of its size.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np

from robolab_ms.catalog.procedural import quat_to_matrix

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

ROOM_MARGIN = 0.015  # m between the object where it is moved in to and a second one of its size beside it


def backed_off(
    free: list[np.ndarray],
    found: tuple[np.ndarray, np.ndarray],
    reached: Callable[[np.ndarray], tuple | None],
    held: np.ndarray,
    grasp: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The release poses `found` (the free spot farthest from the robot that the arm reaches, at the edge of its
    reach, where it takes odd postures and the arm sweeps through a bin's wall on its way back) moved in to the
    farthest free spot of `free` at least PLACE_REACH_MARGIN nearer the robot that `reached` finds a way to, if an
    object of the held one's size still fits beside it there, on a free spot at most as far as `found` (two hammers in one bin need the far
    spot); else `found`. `held`: the held object's points (x, y) relative to the TCP of `grasp`."""
    from robolab_ms.policies.oracle import PLACE_REACH_MARGIN

    edge = float(np.linalg.norm(found[0][:2]))
    nearer = [pose for pose in free if float(np.linalg.norm(pose[:2])) <= edge - PLACE_REACH_MARGIN]
    if not nearer:
        return found
    pose = max(nearer, key=lambda pose: float(np.linalg.norm(pose[:2])))
    low, high = _footprint(pose, held, grasp)
    for other in free:  # within the reach found (the spots beyond it are out of reach)
        if float(np.linalg.norm(other[:2])) > edge:
            continue
        other_low, other_high = _footprint(other, held, grasp)
        if np.any(other_low > high + ROOM_MARGIN) or np.any(low > other_high + ROOM_MARGIN):
            return reached(pose) or found
    return found


def _footprint(pose: np.ndarray, held: np.ndarray, grasp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box (low (x, y), high (x, y)) of the held object's points `held` (relative to the TCP of
    `grasp`) with the TCP at release pose `pose` (turned from `grasp` about the vertical)."""
    turn = quat_to_matrix(pose[3:]) @ quat_to_matrix(grasp[3:]).T
    points = held @ turn[:2, :2].T + pose[:2]
    return points.min(axis=0), points.max(axis=0)


SETTLE_CLEARANCE = 0.01  # m between the open pads' lower ends and the top of an object they barely go round


def settle_pose(env: RoboLabEnv, name: str, grasp: np.ndarray) -> np.ndarray:
    """`grasp` raised until the open pads' lower ends are SETTLE_CLEARANCE above the top of object `name`: where
    the hand waits for the arm to catch up before going down round an object as wide as the open fingers (a tuna
    can), which a pad lagging a few millimetres behind lands on."""
    from robolab_ms.policies.oracle import _world_points
    from robolab_ms.policies.oracle_overhang import PAD_BELOW_TCP

    pose = grasp.copy()
    pose[2] = max(grasp[2], float(_world_points(env, name)[:, 2].max()) + PAD_BELOW_TCP + SETTLE_CLEARANCE)
    return pose


def turned_place(
    env: RoboLabEnv,
    name: str,
    onto: str,
    grasp: np.ndarray,
    held_bottom: float,
    reachable: Callable[[np.ndarray, np.ndarray], bool],
) -> tuple[np.ndarray, np.ndarray] | None:
    """`free_place` with the hand turned about the vertical, by the oracle's PLACE_TURNS in turn (the least turn
    first), for a held object that no free spot of `onto` takes with the hand as it grasped: near the edge of the
    arm's reach the wrist's turn decides whether a pose is reached at all. The first release pose and the pose
    above it that is reached; None where no turn has one."""
    from robolab_ms.policies.oracle import PLACE_TURNS, free_place

    for turn in PLACE_TURNS[1:]:
        spot = free_place(env, name, onto, grasp, held_bottom, reachable, turns=(turn,))
        if spot is not None:
            return spot
    return None
