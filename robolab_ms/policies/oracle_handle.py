"""The oracle's handle grasp: a light standing container too wide for the open fingers that has a long handle (a
measuring cup, a small pan) is held by the handle's outer end, the fingers closing across it from above.

A wall grasp (one finger in the vessel, one outside) touches the wall with one pad first; a light vessel that
leans in a bowl is pushed over by it before the other pad arrives. Around a narrow handle both pads come down
clear of it and close on it from either side.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

HANDLE_MAX_MASS = 0.15  # kg: a container this light is held by its handle (a heavier one would twist out of the pads)
HANDLE_RATIO = 1.5  # a footprint at least this many times as long as wide may have a handle at one end ...
HANDLE_MAX_WIDTH = 0.03  # ... where it is at most this wide (m) within HANDLE_END of its end
HANDLE_END = 0.02  # m from the end of the footprint along its long axis: the points that tell the handle's width
HANDLE_INSET = 0.015  # m in from the handle's end where the middle of the pads closes on it


def handle_grasp(env: RoboLabEnv, name: str, heights: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray | None:
    """A top-down grasp [x, y, z, qw, qx, qy, qz] of the handle of container `name` near its outer end, fingers
    closing across it at the height of its middle; None where `name` is not a light container with a handle (a
    narrow end of an elongated footprint) or where the hand coming down there would hit a neighbour. `heights`:
    the obstacle grid of the oracle's grasp search (None off the CPU simulator: no handle grasp)."""
    from robolab_ms.policies import oracle

    entry = env.eval_context.entries[name]
    if heights is None or not entry.is_container or oracle._mass(env, name) > HANDLE_MAX_MASS:
        return None
    points = oracle._world_points(env, name)
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    narrow, long = vectors[:, 0], vectors[:, 1]
    along, across = points[:, :2] @ long, points[:, :2] @ narrow
    if float(np.ptp(along)) < HANDLE_RATIO * float(np.ptp(across)):
        return None
    best = None
    for end, sign in ((along.max(), 1.0), (along.min(), -1.0)):
        tip = sign * (along - end) > -HANDLE_END  # the points within HANDLE_END of this end
        if tip.sum() < 2 or float(np.ptp(across[tip])) > HANDLE_MAX_WIDTH:
            continue
        at_along = end - sign * HANDLE_INSET
        at_across = (across[tip].max() + across[tip].min()) / 2
        z = float((points[tip, 2].max() + points[tip, 2].min()) / 2)
        position = long * at_along + narrow * at_across
        fingers, body = oracle._hand_clash(heights, position, narrow, z)
        if fingers > oracle.FINGER_CLASH_TOLERANCE or body > oracle.BODY_CLASH_TOLERANCE:
            continue
        if best is None or fingers + body < best[0]:
            best = (fingers + body, position, z)
    if best is None:
        return None
    _, position, z = best
    return np.concatenate([[position[0], position[1], z], oracle._down_quaternion(narrow)])
