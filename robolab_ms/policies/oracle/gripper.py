"""The hand the oracle plans for, as geometry in the TCP frame (x across the fingers' width, y the closing
direction, z towards the fingertips): the open fingers' gap (read from the robot model, `agents.droid_model`), the
pads, and the hand's solids. Every supported robot has DROID's Robotiq 2F-85 or a smaller hand (a Panda's fingers
reach less far), so these are on the safe side for all of them."""

from __future__ import annotations

import functools

import numpy as np

from robolab_ms.agents.droid_model import OPEN_PAD_GAP
from robolab_ms.policies.oracle.geometry import Box, inside_boxes, quat_to_matrix

OPEN_FINGER_GAP = OPEN_PAD_GAP  # m between the open fingers' pads
MAX_GRASP_WIDTH = 0.078  # m: the widest part the open fingers go round with some room (8 mm under the gap)
OPEN_FINGER_REACH = 0.05  # m from the TCP to the outer face of an open finger, along the closing direction
FINGER_HALF_WIDTH = 0.015  # m: object points this near the fingers' plane are between them
PAD_HALF_WIDTH = 0.012  # m from the middle of a finger pad to its edge, across the fingers' plane
PAD_LENGTH = 0.03  # m below the TCP that the pads reach
PAD_BELOW_TCP = 0.006  # m the open pads reach below the TCP
FINGERTIP_BELOW_TCP = 0.01  # m the fingertips reach below the TCP
FINGER_TOP = 0.10  # m above the TCP that the open fingers reach (above it: the gripper's body, narrower)
WRIST_HALF = 0.045  # m from the TCP's axis within which the gripper's body and the coupling to the arm reach
# How far the pads' lower ends reach below the TCP once closed on a part this wide (m): the 2F-85's pads swing
# down as they close (measured on the droid robot).
PAD_DROP_WIDTHS = (0.0, 0.024, 0.036, 0.047, 0.057, 0.067, 0.077, 0.086)
PAD_DROP = (0.020, 0.020, 0.019, 0.0173, 0.0153, 0.0127, 0.0096, 0.0061)
# The hand coming straight down to a top-down grasp, as boxes in its own frame: half extent along the hand's x,
# half extent along the closing direction, and how far below the TCP the box reaches (negative: above it). The
# first box is the open fingers, the others the rest of the hand.
HAND_PARTS = ((0.014, 0.075, 0.008), (0.037, 0.042, -0.053), (0.06, 0.06, -0.155))
HAND_MARGIN = 0.004  # m kept between the hand and anything else on the way down
# The hand as solid boxes in the TCP frame: half extent along the hand's x, half extent along the closing direction,
# and the span along z (the open fingers, the knuckles, the body and the wrist).
HAND_SOLIDS = ((0.014, 0.075, -0.053, 0.0), (0.037, 0.042, -0.155, -0.053), (0.06, 0.06, -0.32, -0.155))
HAND_LENGTH = -HAND_SOLIDS[-1][2]  # m from the TCP back to the wrist
HAND_SAMPLE = 0.01  # m between the points that sample the hand's solids
HAND_FIXTURE_MARGIN = 0.008  # m kept between the hand's solids and a fixture (a shelf)


def pad_drop(width: float) -> float:
    """How far (m) the closed pads' lower ends reach below the TCP on a part `width` wide."""
    return float(np.interp(width, PAD_DROP_WIDTHS, PAD_DROP))


@functools.cache
def hand_samples() -> np.ndarray:
    """Points sampling the hand's solids (HAND_SOLIDS) HAND_SAMPLE apart, in the TCP frame (N, 3)."""
    local = []
    for half_x, half_y, z_from, z_to in HAND_SOLIDS:
        axes = [np.linspace(-h, h, max(2, int(np.ceil(2 * h / HAND_SAMPLE)) + 1)) for h in (half_x, half_y)]
        zs = np.linspace(z_from, z_to, max(2, int(np.ceil((z_to - z_from) / HAND_SAMPLE)) + 1))
        local.append(np.stack(np.meshgrid(*axes, zs), axis=-1).reshape(-1, 3))
    samples = np.concatenate(local)
    samples.setflags(write=False)  # shared by every call
    return samples


def hand_points(pose: np.ndarray) -> np.ndarray:
    """Points sampling the hand's solids (HAND_SOLIDS) at TCP pose [x, y, z, qw, qx, qy, qz], in the world (N, 3)."""
    return hand_samples() @ quat_to_matrix(pose[3:]).T + pose[:3]


def hand_clear(pose: np.ndarray, boxes: list[Box], margin: float = HAND_FIXTURE_MARGIN) -> bool:
    """Whether the hand at TCP `pose` keeps `margin` from every box."""
    return not inside_boxes(hand_points(pose), boxes, margin)
