"""The oracle's high carry: a held object carried over whatever stands on its way to the place.

The lift raises a held object above its near neighbours only (those within the oracle's TRAVEL_RADIUS of the
grasp), and the carry to the place is a joint-space move. A tall object farther along the way (a ketchup bottle
between a mug and the bin) is then met by the hanging object, which is knocked out of the fingers. Where the
straight way from the lifted pose to the pose over the place passes too low over anything but the object itself
and its destination (between the two: the lifted pose and the pose over the place clear their own surroundings),
the object is lifted to a height that clears all of it and carried across at that height, then lowered to the pose
over the place: never higher than that pose, and not onto a shelf (whose levels may be reached from the front).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

CARRY_SAMPLES = 40  # points along the way at which what lies below is looked at
CARRY_MARGIN = 0.03  # m added to the held object's horizontal spread around the TCP when looking for what is below
CARRY_TOLERANCE = 0.01  # m the way may dip below the needed height before it is raised (keeps clear ways as they are)


def held_spread(env: RoboLabEnv, name: str, grasp: np.ndarray) -> float:
    """How far (m, horizontally) object `name` reaches from the TCP of `grasp` once held."""
    from robolab_ms.policies.oracle import _world_points

    return float(np.linalg.norm(_world_points(env, name)[:, :2] - grasp[:2], axis=1).max())


def carry_height(
    env: RoboLabEnv, name: str, start: np.ndarray, end: np.ndarray, hanging: float, spread: float, onto: str | None
) -> float | None:
    """A TCP height from which object `name`, hanging `hanging` m below the TCP and reaching `spread` m around it,
    passes TRAVEL_CLEARANCE above every other object (but its destination `onto`) near the straight way from TCP
    position `start` to `end`, of those parts farther than TRAVEL_RADIUS from both ends (the lifted pose and the
    pose over the place already clear what is near them); None where that way, at its own heights, clears them all."""
    from robolab_ms.policies.oracle import TRAVEL_CLEARANCE, TRAVEL_RADIUS, _world_points

    fractions = np.linspace(0.0, 1.0, CARRY_SAMPLES)
    way = start[None, :3] + fractions[:, None] * (end[:3] - start[:3])[None, :]
    radius = spread + CARRY_MARGIN
    need, highest = -np.inf, -np.inf
    for other in env.objects:
        if other in (name, onto):
            continue
        points = _world_points(env, other)
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
    """The lifted pose raised to clear what stands on the way to `above_place`, and the pose over the place at that
    height (from which the object is lowered to `above_place`); None where the way is clear as it is, or where
    clearing it takes a height above `above_place` (the way is then left as it was)."""
    if onto is not None and env.eval_context.entries[onto].is_fixture:  # a shelf: its levels are reached from the
        return None  # front where they are too high to reach from above, a way planned from the lift as it was
    height = carry_height(env, name, lifted, above_place, hanging, spread, onto)
    if height is None or height > above_place[2] + 1e-3:  # never above the pose over the place (a high shelf level:
        return None  # raised further, the arm cannot slide the object in from the front)
    raised, transit = lifted.copy(), above_place.copy()
    raised[2] = max(lifted[2], height)
    transit[2] = max(above_place[2], height)
    return raised, transit
