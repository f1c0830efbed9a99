"""The oracle's hold of a heavy or long tool whose widest part is walled in (a drill standing in a bin).

grasp_pose holds an object at the widest section that fits between the open fingers, lower down where it is wider
(round things through their middle). A drill standing in a bin is widest at its battery, down by the bin's floor,
where the open fingers would meet the bin's walls; grasp_pose then turned the hand to close along the drill's
length, on no part that fits. Such a tool is held higher up instead, GRASP_DEPTH below its top (a drill across
its body, over its centre of mass), where the fingers clear the walls.
"""

from __future__ import annotations

import numpy as np


Hold = tuple[float, float, float, float]  # TCP height, width closed on, fingers' clash, the rest of the hand's clash


def higher_hold(slab: np.ndarray, closing: np.ndarray, heights: tuple[np.ndarray, np.ndarray] | None,
                xy: np.ndarray, lower: Hold) -> Hold:  # fmt: skip
    """A top-down hold of a tool at (x, y) `xy`, the fingers closing along `closing` (horizontal unit vector),
    GRASP_DEPTH below the top of `slab` (the tool's world points between the fingers): the TCP height, the width
    the fingers close on there (the slab from just below that height up), and how far anything else rises into
    the space of the fingers and of the rest of the hand (`_hand_clash` of the oracle's obstacle grid `heights`).
    `lower` (the hold grasp_pose found, in the same terms) where that one is not lower (a flat tool)."""
    from robolab_ms.policies.oracle import GRASP_DEPTH, SECTION_STEP, _hand_clash

    z = float(slab[:, 2].max()) - GRASP_DEPTH
    if z <= lower[0] + SECTION_STEP:
        return lower
    section = slab[slab[:, 2] >= z - 2 * SECTION_STEP]
    width = float(np.ptp(section[:, :2] @ closing)) if len(section) >= 2 else 0.0
    fingers, body = _hand_clash(heights, xy, closing, z)
    return z, width, fingers, body
