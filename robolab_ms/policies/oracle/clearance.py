"""Heights at which the hand, or the object it holds, passes over the scene: over a grasp or a place
(`above`), on the way to a grasp (`pass_height`, and `sag_height` along the path the arm really takes), and on the
carry to a place (`high_carry`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.policies.oracle.gripper import FINGERTIP_BELOW_TCP
from robolab_ms.policies.oracle.world import world_points

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

APPROACH_HEIGHT = 0.10  # m above the grasp, and above the place point, where straight moves start and end
LIFT_HEIGHT = 0.15  # m an object is lifted before it travels
TRAVEL_RADIUS = 0.15  # m: objects this near (horizontally) a pose above a grasp or a place point ...
TRAVEL_CLEARANCE = 0.04  # ... are passed this high above, by the fingertips or the held object
PASS_RADIUS = 0.08  # m (horizontally) from the hand's way to a grasp within which objects must be passed above ...
PASS_SAMPLES = 25  # ... checked at this many points along the way
SAG_REACH = 0.075  # m: object points this near the TCP (horizontally) are under the open fingers (their outer ends)
SAG_MARGIN = 0.005  # m: the fingertips passing less than this above such a point catch on it
CARRY_SAMPLES = 40  # points along the way at which what lies below is looked at
CARRY_MARGIN = 0.03  # m added to the held object's horizontal spread around the TCP when looking for what is below
CARRY_TOLERANCE = 0.01  # m the way may dip below the needed height before it is raised (keeps clear ways as they are)


def above(env: RoboLabEnv, pose: np.ndarray, height: float, hanging: float, held: str | None = None) -> np.ndarray:
    """`pose` raised by `height`, and further if needed so that whatever hangs `hanging` metres below the TCP (the
    held object; else the fingertips) passes TRAVEL_CLEARANCE above every object (but `held`) within TRAVEL_RADIUS."""
    tops = [
        points[np.linalg.norm(points[:, :2] - pose[:2], axis=1) < TRAVEL_RADIUS, 2].max(initial=0.0)
        for points in (world_points(env, name) for name in env.objects if name != held)
    ]
    lifted = pose.copy()
    lifted[2] = max(pose[2] + height, max(tops, default=0.0) + TRAVEL_CLEARANCE + max(hanging, FINGERTIP_BELOW_TCP))
    return lifted


def pass_height(env: RoboLabEnv, start: np.ndarray, end: np.ndarray, name: str) -> float | None:
    """A TCP height from which the fingertips pass TRAVEL_CLEARANCE above every object but `name` near the
    straight way from TCP position `start` to `end` (within PASS_RADIUS of it, horizontally); None where that way
    itself clears them all (the height is then not needed)."""
    fractions = np.linspace(0.0, 1.0, PASS_SAMPLES)
    way = start[None, :] + fractions[:, None] * (end - start)[None, :]
    need, highest = -np.inf, -np.inf
    for other in env.objects:
        if other == name:
            continue
        points = world_points(env, other)
        distance = np.linalg.norm(points[None, :, :2] - way[:, None, :2], axis=2)  # (samples, points)
        near = distance < PASS_RADIUS
        if not near.any():
            continue
        tops = np.where(near, points[None, :, 2], -np.inf).max(axis=1) + TRAVEL_CLEARANCE + FINGERTIP_BELOW_TCP
        need = max(need, float((tops - way[:, 2]).max()))
        highest = max(highest, float(tops.max()))
    if need <= 0.0:
        return None
    return max(highest, float(end[2]))


def sag_height(env: RoboLabEnv, way: np.ndarray, name: str) -> float | None:
    """For the TCP positions `way` (steps, 3) of a planned reach towards object `name`: None where the open
    fingertips stay above every other object's surface under them all the way; else the TCP height from which the
    hand passes TRAVEL_CLEARANCE above everything near the way (as `pass_height` measures it). A joint-space path
    can run centimetres below the straight line between its ends, and an open finger that dips onto a crate's
    rim on the way pulls the crate over."""
    snag, highest = False, -np.inf
    for other in env.objects:
        if other == name:
            continue
        points = world_points(env, other)
        distance = np.linalg.norm(points[None, :, :2] - way[:, None, :2], axis=2)  # (steps, points)
        under = distance < SAG_REACH
        if under.any():
            tops = np.where(under, points[None, :, 2], -np.inf).max(axis=1)
            snag = snag or bool((way[:, 2] - FINGERTIP_BELOW_TCP - SAG_MARGIN < tops).any())
        near = distance < PASS_RADIUS
        if near.any():
            highest = max(highest, float(points[near.any(axis=0), 2].max()))
    if not snag:
        return None
    return highest + TRAVEL_CLEARANCE + FINGERTIP_BELOW_TCP


def held_spread(env: RoboLabEnv, name: str, grasp: np.ndarray) -> float:
    """How far (m, horizontally) object `name` reaches from the TCP of `grasp` once held."""
    return float(np.linalg.norm(world_points(env, name)[:, :2] - grasp[:2], axis=1).max())


def carry_height(
    env: RoboLabEnv, name: str, start: np.ndarray, end: np.ndarray, hanging: float, spread: float, onto: str | None
) -> float | None:
    """A TCP height from which object `name`, hanging `hanging` m below the TCP and reaching `spread` m around it,
    passes TRAVEL_CLEARANCE above every other object (but its destination `onto`) near the straight way from TCP
    position `start` to `end`, of those parts farther than TRAVEL_RADIUS from both ends (the lifted pose and the
    pose over the place already clear what is near them); None where that way, at its own heights, clears them all."""
    fractions = np.linspace(0.0, 1.0, CARRY_SAMPLES)
    way = start[None, :3] + fractions[:, None] * (end[:3] - start[:3])[None, :]
    radius = spread + CARRY_MARGIN
    need, highest = -np.inf, -np.inf
    for other in env.objects:
        if other in (name, onto):
            continue
        points = world_points(env, other)
        ends = np.linalg.norm(points[:, None, :2] - np.stack([start[:2], end[:2]])[None], axis=2).min(axis=1)
        points = points[ends >= TRAVEL_RADIUS]  # the lift and the pose over the place clear those near them
        near = np.linalg.norm(points[None, :, :2] - way[:, None, :2], axis=2) < radius  # (samples, points)
        if not near.any():
            continue
        tops = np.where(near, points[None, :, 2], -np.inf).max(axis=1) + TRAVEL_CLEARANCE + hanging
        need = max(need, float((tops - way[:, 2]).max()))
        highest = max(highest, float(tops.max()))
    if need <= CARRY_TOLERANCE:
        return None
    return highest


def high_carry(
    env: RoboLabEnv,
    name: str,
    lifted: np.ndarray,
    above_place: np.ndarray,
    hanging: float,
    spread: float,
    onto: str | None,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The lifted pose raised to clear what stands on the way to `above_place` (a tall bottle between the object
    and the bin knocks a hanging object out of the fingers), and the pose over the place at that height (from which
    the object is lowered to `above_place`); None where the way is clear as it is, where clearing it takes a height
    above `above_place`, or onto a fixture (a shelf, whose levels may have to be reached from the front)."""
    if onto is not None and env.eval_context.entries[onto].is_fixture:
        return None
    height = carry_height(env, name, lifted, above_place, hanging, spread, onto)
    if height is None or height > above_place[2] + 1e-3:  # never above the pose over the place (a high shelf level:
        return None  # raised further, the arm cannot slide the object in from the front)
    lifted_high, transit = lifted.copy(), above_place.copy()
    lifted_high[2] = max(lifted[2], height)
    transit[2] = max(above_place[2], height)
    return lifted_high, transit
