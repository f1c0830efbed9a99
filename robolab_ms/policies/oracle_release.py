"""The oracle's release of a round object as wide as the open fingers (a tuna can).

Opened, the pads still touch such an object, and the hand lifted straight away carries it up between them. Moving
the hand along the pads' width (across the closing direction) takes both pads off a round object at once: the
farther from its middle, the narrower its chord between them. The slide is the shortest of SLIDE_STEPS after which
the object between the pads' new place is at most OPEN_FINGER_GAP - SLIDE_ROOM wide, towards the middle of what it
was set on (away from the walls of a bin); None where no slide that short clears it (a box: its width stays).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np

from robolab_ms.catalog.procedural import quat_to_matrix

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

SLIDE_STEPS = (0.02, 0.025, 0.03, 0.035, 0.04, 0.045)  # m the hand may move along the pads' width, shortest first
SLIDE_ROOM = 0.012  # m the object's chord between the pads' new place is narrower than the open fingers' gap
PAD_HALF_WIDTH = 0.012  # m to either side of the TCP that a pad covers, along its width
SLAB_HALF_HEIGHT = 0.01  # m above and below the TCP within which the object's points count


def pad_slide(env: RoboLabEnv, name: str, grasp: np.ndarray, place: np.ndarray,
              towards: np.ndarray) -> np.ndarray | None:  # fmt: skip
    """The horizontal offset (x, y, 0) that moves the open hand at release pose `place` (holding `name` as by
    `grasp`, before the grasp) off a round object along the pads' width, on the side of `towards` (x, y); None
    where no step of SLIDE_STEPS frees both pads."""
    from robolab_ms.policies.oracle import OPEN_FINGER_GAP, _world_points

    rotation = quat_to_matrix(grasp[3:])
    local = (_world_points(env, name) - grasp[:3]) @ rotation  # in the hand's frame: x along the pads' width
    slab = local[np.abs(local[:, 2]) < SLAB_HALF_HEIGHT]
    if len(slab) < 8:
        return None
    width_axis = quat_to_matrix(place[3:])[:, 0] * np.array([1.0, 1.0, 0.0])
    if np.linalg.norm(width_axis) < 1e-6:
        return None
    width_axis /= np.linalg.norm(width_axis)
    sign = 1.0 if float(width_axis[:2] @ towards) >= 0.0 else -1.0
    for step in SLIDE_STEPS:
        band = slab[np.abs(slab[:, 0] - sign * step) < PAD_HALF_WIDTH]
        chord = float(np.ptp(band[:, 1])) if len(band) >= 2 else 0.0
        if chord <= OPEN_FINGER_GAP - SLIDE_ROOM:
            return sign * step * width_axis
    return None


def backed_off(free: list[np.ndarray], found: tuple[np.ndarray, np.ndarray],
               reached: Callable[[np.ndarray], tuple | None]) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The release poses `found` (the free spot farthest from the robot that the arm reaches, at the edge of its
    reach, where it takes odd postures and a wide hand meets a bin's far wall) moved in to the farthest free spot
    of `free` at least PLACE_REACH_MARGIN nearer the robot that `reached` finds a way to; `found` where there is none."""
    from robolab_ms.policies.oracle import PLACE_REACH_MARGIN

    edge = float(np.linalg.norm(found[0][:2]))
    nearer = [pose for pose in free if float(np.linalg.norm(pose[:2])) <= edge - PLACE_REACH_MARGIN]
    if not nearer:
        return found
    return reached(max(nearer, key=lambda pose: float(np.linalg.norm(pose[:2])))) or found
