"""The oracle's chord grasp: a round object as wide as the open fingers, or wider, held off its middle.

A tuna can (8.6 cm) is as wide as the open fingers' gap: grasped through its middle, the opened pads still press on
it, and the hand lifts it back out of the bin. A coffee can (10.2 cm) does not fit between them at all. Both are
round, so a pair of pads moved sideways (along their own width) off the middle closes on a chord of the circle,
narrower than its diameter: the hand is moved out until the widest chord between the pads leaves room inside the
open fingers, and the pads' inner edges close on the can's side (friction holds the can, which the squeeze pushes
gently out along the pads). Used only where no grasp of the object fits between the open fingers, its section is
round and its sides are straight (a standing can): a box, a ball or a figurine is left to the ordinary grasp.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

ROUNDNESS = 1.08  # a section whose widest spread is at most this many times its narrowest is round
ROUND_DIRECTIONS = 24  # horizontal directions in which the spread is measured for roundness
CHORD_STEP = 0.003  # m between the sideways shifts tried
CHORD_ROOM = 0.002  # m the widest chord between the pads is narrower than MAX_GRASP_WIDTH (room on the way down)
END_SHARE = 0.2  # the top and the bottom part of an object's height, whose widths are compared with the whole
STRAIGHT_SHARE = 0.95  # a part at least this share of the whole width is as wide
MIN_CHORD_SHARE = 0.6  # the chord held is at least this share of the diameter (the pads' edges keep a hold)


def round_section(points: np.ndarray) -> bool:
    """Whether the horizontal spread of `points` is about the same in every direction (a can, a cylinder)."""
    angles = np.linspace(0.0, np.pi, ROUND_DIRECTIONS, endpoint=False)
    widths = np.ptp(points[:, :2] @ np.stack([np.cos(angles), np.sin(angles)]), axis=0)
    return float(widths.max()) <= ROUNDNESS * float(widths.min())


def straight_sided(points: np.ndarray) -> bool:
    """Whether the object of `points` is as wide at its top and at its bottom as overall, within STRAIGHT_SHARE (a
    standing can; not a ball or a fruit, whose width the pads meet only at one height, nor a bottle's neck)."""
    low, high = points[:, 2].min(), points[:, 2].max()
    overall = float(np.ptp(points[:, :2], axis=0).min())
    for end in (points[:, 2] >= high - END_SHARE * (high - low), points[:, 2] <= low + END_SHARE * (high - low)):
        if end.sum() < 2 or float(np.ptp(points[end, :2], axis=0).min()) < STRAIGHT_SHARE * overall:
            return False
    return True


def chord_grasp(
    env: RoboLabEnv,
    name: str,
    points: np.ndarray,
    centre: np.ndarray,
    directions: list[np.ndarray],
    bottom: float,
    heights,
    failed: list[np.ndarray],
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """(xy, z, closing) of a grasp of the round object `name` (world `points`, footprint middle `centre`) off its
    middle, where the widest chord between the pads (FINGER_HALF_WIDTH either side of their line; a circle of the
    object's radius, as its surface points may be sparse) is CHORD_ROOM narrower than MAX_GRASP_WIDTH; None where
    the object is no standing can (`round_section`, `straight_sided`), a grasp through its middle fits, or no chord
    does. Of the closing `directions` and the two sides, the one whose hand clears the neighbours best, then the
    one away from grasps in `failed`, then the nearest to the robot (the arm reaches it most easily)."""
    from robolab_ms.policies.oracle import (
        CLASH_COST,
        FINGER_HALF_WIDTH,
        MAX_GRASP_WIDTH,
        MIN_SLAB_POINTS,
        _grasp_height,
        _hand_clash,
        _near_failed,
    )

    if env.eval_context.entries[name].is_container or not round_section(points) or not straight_sided(points):
        return None
    radius = float(np.linalg.norm(points[:, :2] - centre[:2], axis=1).max())
    best, best_key = None, None
    for rank, direction in enumerate(directions):
        direction = direction / np.linalg.norm(direction)
        along = np.array([-direction[1], direction[0]])
        offsets = points[:, :2] @ along - centre[:2] @ along
        middle = points[np.abs(offsets) < FINGER_HALF_WIDTH]
        if len(middle) >= 2 and float(np.ptp(middle[:, :2] @ direction)) <= MAX_GRASP_WIDTH:
            return None  # it fits through the middle: the ordinary grasp
        for side in (1.0, -1.0):
            for shift in np.arange(FINGER_HALF_WIDTH, radius + FINGER_HALF_WIDTH, CHORD_STEP):
                inner = shift - FINGER_HALF_WIDTH  # the pads' edge nearest the middle: the widest chord is there
                chord = 2.0 * float(np.sqrt(max(radius**2 - inner**2, 0.0)))
                if chord < MIN_CHORD_SHARE * 2 * radius:
                    break
                if chord > MAX_GRASP_WIDTH - CHORD_ROOM:
                    continue
                xy = centre[:2] + along * side * shift
                slab = points[np.abs(offsets - side * shift) < FINGER_HALF_WIDTH]
                z, _ = _grasp_height(slab if len(slab) >= MIN_SLAB_POINTS else points, direction, bottom)
                fingers, body = _hand_clash(heights, xy, direction, z)
                key = (
                    round(CLASH_COST * (fingers + body), 3),
                    _near_failed(xy, direction, failed),
                    float(np.linalg.norm(xy)) + 0.005 * rank,
                )
                if best_key is None or key < best_key:
                    best, best_key = (xy, z, direction), key
                break
    return best
