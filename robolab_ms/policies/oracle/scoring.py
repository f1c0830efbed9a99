"""The terms grasp candidates are ranked by, each named for what it measures: how far a neighbour rises into the
space the open fingers and the rest of the hand sweep on the way down (`hand_clash`), how much of that is more than
the hand pushes aside (`blocked`), whether the closing pads swing down onto a neighbour (`pads_snag`), whether a
candidate repeats a grasp whose job failed (`near_failed`), how near a fixture the arm passes (`fixture_closeness`),
and the cost of moving and turning the hand off the object's middle and of a wide hold (`grasp_cost`). A generator
puts them in a `GraspScore`, whose `key` orders candidates (smallest first)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robolab_ms.policies.oracle.geometry import Box, quat_to_matrix
from robolab_ms.policies.oracle.gripper import HAND_MARGIN, HAND_PARTS, OPEN_FINGER_REACH, PAD_HALF_WIDTH, pad_drop
from robolab_ms.policies.oracle.world import Grid

CLASH_COST = 0.1  # m of shift that a metre of neighbour in the hand's way is worth (the hand pushes it aside) ...
BODY_CLASH_TOLERANCE = 0.08  # ... as long as it rises at most this far into the space of the gripper's body
FINGER_CLASH_TOLERANCE = 0.03  # ... and at most this far into the space the open fingers sweep
FINGER_SNAG = 0.005  # m: a neighbour rising this far into the open fingers' space may be pinched with the object,
# so a grasp whose fingers clear every neighbour (and that fits between them) wins over the untouched one
WIDTH_COST = 2.0  # m of shift that a metre more between the closed fingers is worth (a narrow hold is firm) ...
FIRM_WIDTH = 0.05  # ... down to this width (narrower is no firmer: a thin handle or knob is no better a hold)
TURN_COST = 0.005  # m of shift that one step of turn away from the preferred closing direction is worth
FAILED_GRASP_RADIUS = 0.025  # m: a grasp this near one whose job failed (same closing within 30 degrees) comes last
FAILED_GRASP_TURN = 30.0  # degrees
FIXTURE_CLEARANCE = 0.12  # m (horizontally) from a fixture's piece above it within which a grasp's arm comes close


def hand_clash(heights: Grid | None, xy: np.ndarray, closing: np.ndarray, z: float) -> tuple[float, float]:
    """How far (m) anything in the obstacle grid `heights` rises into the space that the open fingers, and the rest
    of the hand, sweep coming straight down to a grasp at (xy, z) with the fingers closing along `closing`: (fingers,
    body); (0, 0) when the way is clear or there is no grid (off the CPU simulator)."""
    if heights is None:
        return 0.0, 0.0
    cells, tops = heights
    along = np.array([-closing[1], closing[0]])
    local = cells - xy
    u, v = np.abs(local @ along), np.abs(local @ closing)
    clashes = []
    for half_u, half_v, reach in HAND_PARTS:
        inside = (u <= half_u + HAND_MARGIN) & (v <= half_v + HAND_MARGIN)
        clashes.append(max(float(tops[inside].max(initial=-np.inf)) - (z - reach), 0.0))
    return clashes[0], max(clashes[1:])


def blocked(fingers: float, body: float) -> float:
    """How far (m) a neighbour rises into the hand's way beyond what the hand pushes aside (the clash tolerances):
    the hand lands on it, or a finger catches on it."""
    return max(body - BODY_CLASH_TOLERANCE, 0.0) + max(fingers - FINGER_CLASH_TOLERANCE, 0.0)


def clears(fingers: float, body: float) -> bool:
    """Whether the hand's way down is within both clash tolerances."""
    return not (fingers > FINGER_CLASH_TOLERANCE or body > BODY_CLASH_TOLERANCE)


def pads_snag(heights: Grid | None, xy: np.ndarray, closing: np.ndarray, z: float, width: float) -> bool:
    """Whether anything in the obstacle grid `heights` rises above the lower ends of the closed pads anywhere the
    open pads sweep on their way to a part `width` wide held at (xy, z), the fingers closing along `closing`:
    within the open finger's outer face along the closing direction and the pads' width across it. The pads swing
    down as they close, so a neighbour only a centimetre high beside a thin object lying on the table (a plate's rim
    beside a fork) is pinched with it, though the hand's boxes of `hand_clash` see it clear. False without a grid."""
    if heights is None:
        return False
    cells, tops = heights
    closing = closing / np.linalg.norm(closing)
    along = np.array([-closing[1], closing[0]])
    local = cells - xy
    u, v = np.abs(local @ along), np.abs(local @ closing)
    inside = (u <= PAD_HALF_WIDTH + HAND_MARGIN) & (v <= OPEN_FINGER_REACH + HAND_MARGIN)
    return bool(float(tops[inside].max(initial=-np.inf)) > z - pad_drop(width))


def near_failed(xy: np.ndarray, closing: np.ndarray, failed: list[np.ndarray]) -> bool:
    """Whether a grasp at `xy` closing along `closing` is within FAILED_GRASP_RADIUS of one in `failed` (TCP poses
    of grasps whose job did not succeed), closing along nearly the same line."""
    for pose in failed:
        other = quat_to_matrix(pose[3:])[:2, 1]  # the hand's y axis: its closing direction
        if np.linalg.norm(pose[:2] - xy) < FAILED_GRASP_RADIUS and abs(float(closing @ other)) > np.cos(
            np.radians(FAILED_GRASP_TURN)
        ):
            return True
    return False


def fixture_closeness(boxes: list[Box], xy: np.ndarray, z: float) -> float:
    """How far (m) a top-down grasp at (`xy`, `z`) is inside FIXTURE_CLEARANCE of the nearest of the fixture
    `boxes` that reaches above it (a shelf's board or leg beside it, not the board it stands on): 0 where none is
    that near. The descending arm passes such a piece within centimetres, so the side of a wide container away
    from it is the better one to hold."""
    worst = 0.0
    for rotation, middle, half in boxes:
        if float(middle[2] + np.abs(rotation[2]) @ half) <= z + 0.05:
            continue
        local = np.abs((np.array([xy[0], xy[1], middle[2]]) - middle) @ rotation)[:2]
        outside = np.maximum(local - half[:2], 0.0)  # (boxes of the fixtures stand upright: x, y span the floor)
        worst = max(worst, FIXTURE_CLEARANCE - float(np.linalg.norm(outside)))
    return worst


def grasp_cost(shift: float, turn_rank: int, fingers: float, body: float, width: float | None = None) -> float:
    """The cost (in metres of shift) of a top-down candidate moved `shift` along the part from its middle, turned
    `turn_rank` steps from the preferred closing direction, with the hand's clash (`fingers`, `body`) and, where
    given, the `width` the fingers close on (a narrow hold is firm, down to FIRM_WIDTH)."""
    cost = abs(shift) + TURN_COST * turn_rank + CLASH_COST * (fingers + body)
    if width is not None:
        cost = cost + WIDTH_COST * max(width, FIRM_WIDTH)
    return cost


@dataclass(frozen=True)
class GraspScore:
    """The named terms of a top-down candidate, in the order they rank it: near a failed grasp, blocked at all, how
    far blocked, snagging a neighbour (or too wide, or turned too far for the object), moved or turned off the
    preferred grasp at all, and the cost."""

    failed_nearby: bool
    blocked: float
    snag: bool
    moved: bool
    cost: float

    @property
    def key(self) -> tuple:
        return (self.failed_nearby, self.blocked > 0.0, round(self.blocked, 3), self.snag, self.moved, self.cost)
