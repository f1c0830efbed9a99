"""The oracle's check of the closing pads' sweep for a light long object (a fork, a spoon) lying beside something
low (a plate's rim): the open fingers come down a few millimetres above the table next to the object, and the pads
swing down as they close, so a neighbour only a centimetre high within the open fingers' reach is pinched with the
object (the hand's boxes in `oracle._hand_clash` reach less far below the TCP and see such a neighbour clear).
"""

from __future__ import annotations

import numpy as np


def pads_snag(
    heights: tuple[np.ndarray, np.ndarray] | None, xy: np.ndarray, closing: np.ndarray, z: float, width: float
) -> bool:
    """Whether anything in the obstacle grid `heights` (cell centres, tops; the oracle's `_obstacle_heights`) rises
    above the lower ends of the closed pads anywhere the open pads sweep on their way to a part `width` wide held at
    (xy, z), the fingers closing along `closing`: within the open finger's outer face along the closing direction
    and the pads' width across it. False without a grid (off the CPU simulator)."""
    from robolab_ms.policies import oracle

    if heights is None:
        return False
    cells, tops = heights
    closing = closing / np.linalg.norm(closing)
    along = np.array([-closing[1], closing[0]])
    local = cells - xy
    u, v = np.abs(local @ along), np.abs(local @ closing)
    inside = (u <= oracle.PAD_HALF_WIDTH + oracle.HAND_MARGIN) & (v <= oracle.OPEN_FINGER_REACH + oracle.HAND_MARGIN)
    drop = float(np.interp(width, oracle.PAD_DROP_WIDTHS, oracle.PAD_DROP))
    return bool(float(tops[inside].max(initial=-np.inf)) > z - drop)
