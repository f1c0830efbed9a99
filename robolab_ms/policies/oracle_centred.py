"""The oracle's grasp of a light long object (a wooden spoon) whose chosen grasp leaves its thin handle beside the
middle of the open fingers. The candidate grasps of `oracle.grasp_pose` move the hand along its own width, so one
turned from across the object and moved along it can put the handle next to a pad (measured on the object's few
hull corners, the part looks centred): that pad reaches the handle first, pushes it across the table and turns it
before the other closes, and the lifted spoon slips out of the closed hand. Only where an open finger of the chosen
grasp comes down on the part, measured on the object's ray-cast top, is a grasp chosen again among ones moved along
the object's long axis and centred between the pads.
"""

from __future__ import annotations

import numpy as np


def band_offset(footprint: np.ndarray, xy: np.ndarray, closing: np.ndarray) -> tuple[float, float] | None:
    """How far (m) along horizontal unit `closing` the middle of the object part between fingers at `xy` lies from
    `xy`, and how wide it is along `closing`, measured on `footprint` (the oracle's `_footprint_points`); None where
    too little of the object lies between the fingers."""
    from robolab_ms.policies import oracle

    along = np.array([-closing[1], closing[0]])
    slab = footprint[np.abs(footprint[:, :2] @ along - xy @ along) < oracle.FINGER_HALF_WIDTH]
    if len(slab) < oracle.MIN_SLAB_POINTS:
        return None
    across = slab[:, :2] @ closing - xy @ closing
    return float((across.max() + across.min()) / 2), float(np.ptp(across))


def off_part(footprint: np.ndarray | None, xy: np.ndarray, closing: np.ndarray) -> bool:
    """Whether an open finger of a grasp at `xy` closing along `closing` comes down on the object seen from above
    as `footprint`: its part between the fingers reaches past a finger's outer face (False where it cannot be
    measured)."""
    from robolab_ms.policies import oracle

    if footprint is None:
        return False
    closing = closing / np.linalg.norm(closing)
    measured = band_offset(footprint, xy, closing)
    return measured is not None and abs(measured[0]) + measured[1] / 2 > oracle.OPEN_FINGER_REACH


def centred_grasp(
    footprint: np.ndarray, directions: list[np.ndarray], bottom: float, heights: tuple[np.ndarray, np.ndarray] | None
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """(xy, z, closing) of a top-down grasp of a light long object seen from above as `footprint`: the hand on the
    object's long axis, moved along it by one of the oracle's GRASP_SHIFTS, closing along one of `directions` (the
    turns of the oracle's GRASP_TURNS, in order), and then moved along the closing direction until the part between
    the fingers is centred. Of these the one whose open fingers and hand clear the neighbours (obstacle grid
    `heights`), then whose closing pads pinch none and which is turned at most LONG_MAX_TURN from across the
    object, then the nearest the middle and least turned; None where every one is blocked."""
    from robolab_ms.policies import oracle
    from robolab_ms.policies.oracle_pads import pads_snag

    xy_all = footprint[:, :2]
    middle = (xy_all.max(axis=0) + xy_all.min(axis=0)) / 2
    spread = xy_all - xy_all.mean(axis=0)
    _, vectors = np.linalg.eigh(spread.T @ spread)
    axis = vectors[:, 1]
    limit = oracle.MAX_SHIFT_SHARE * float(np.ptp(xy_all @ axis))
    best, best_key = None, None
    for turn_rank, direction in enumerate(directions):
        direction = direction / np.linalg.norm(direction)
        along = np.array([-direction[1], direction[0]])
        for shift in [v for v in oracle.GRASP_SHIFTS if abs(v) <= limit]:
            xy = middle + axis * shift
            measured = band_offset(footprint, xy, direction)
            if measured is None or measured[1] > oracle.MAX_GRASP_WIDTH:
                continue
            xy = xy + direction * measured[0]
            slab = footprint[np.abs(footprint[:, :2] @ along - xy @ along) < oracle.FINGER_HALF_WIDTH]
            z, width = oracle._grasp_height(slab, direction, bottom)
            fingers, body = oracle._hand_clash(heights, xy, direction, z)
            blocked = max(body - oracle.BODY_CLASH_TOLERANCE, 0.0) + max(fingers - oracle.FINGER_CLASH_TOLERANCE, 0.0)
            snag = (
                width > oracle.MAX_GRASP_WIDTH
                or pads_snag(heights, xy, direction, z, width)
                or (abs(oracle.GRASP_TURNS[turn_rank]) > oracle.LONG_MAX_TURN)
            )  # turned far from across it
            cost = abs(shift) + oracle.TURN_COST * turn_rank + oracle.CLASH_COST * (fingers + body)
            key = (blocked > 0.0, round(blocked, 3), snag, cost)
            if best_key is None or key < best_key:
                best, best_key = (xy, z, direction), key
    if best is None or best_key[0]:
        return None
    return best
