"""Reorientation grasps of the oracle for objects that the rim grasp and the lift-and-turn grasp do not serve.

A lying object too wide to hold across its body (a jug on its side) is held from above by the narrow part at its
top end (a neck) and tipped up about its base, which stays on the table (the oracle's pivot move). A mug standing
upside down is pinched by its handle's loop with the hand level and pointing at the mug, lifted a little, turned
half a turn about the hand's own axis (the last wrist joint alone) and set down on its base.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

END_DEPTHS = np.arange(0.015, 0.08, 0.005)  # m from a lying object's top end where a grasp on its end is tried
END_HALF_SPAN = 0.012  # m: points this near the grasp's line across the axis lie between the pads (their half width)
END_MIN_POINTS = 6  # the fewest surface points between the pads that tell the width there
END_WIDTH_TOLERANCE = 0.002  # m: sections this close to the narrowest count as equally narrow; the middle one is held


def end_grasp(env: RoboLabEnv, name: str, up: np.ndarray) -> np.ndarray | None:
    """A top-down grasp [x, y, z, qw, qx, qy, qz] of the top end of lying object `name` (the end its up axis `up`
    points to): the fingers close horizontally across its axis on the narrowest section near that end that fits
    between the open fingers (a neck), in the middle of the run of sections about as narrow; None if none fits."""
    from robolab_ms.policies.oracle import MAX_GRASP_WIDTH, _down_quaternion, _grasp_height, _world_points

    env.eval_context.refresh()
    points = _world_points(env, name)
    flat = np.array([up[0], up[1]], dtype=np.float64)
    flat /= np.linalg.norm(flat)
    closing = np.array([-flat[1], flat[0]])
    along, across = points[:, :2] @ flat, points[:, :2] @ closing
    end, bottom = float(along.max()), float(points[:, 2].min())
    sections = []  # (width, depth)
    for depth in END_DEPTHS:
        near = np.abs(along - (end - depth)) < END_HALF_SPAN
        if near.sum() >= END_MIN_POINTS and np.ptp(across[near]) <= MAX_GRASP_WIDTH:
            sections.append((float(np.ptp(across[near])), float(depth)))
    if not sections:
        return None
    narrowest = min(width for width, _ in sections)
    depths = [depth for width, depth in sections if width <= narrowest + END_WIDTH_TOLERANCE]
    depth = depths[len(depths) // 2]
    slab = points[np.abs(along - (end - depth)) < END_HALF_SPAN]
    middle = (float((slab[:, :2] @ closing).max()) + float((slab[:, :2] @ closing).min())) / 2
    xy = flat * (end - depth) + closing * middle
    z, _ = _grasp_height(slab, closing, bottom)
    return np.concatenate([[xy[0], xy[1], z], _down_quaternion(closing, keep_sign=True)])


RIM_YAWS = (0.0, 20.0, -20.0, 35.0, -35.0, 50.0, -50.0)  # degrees a rim grasp's hand turns about the vertical ...
RIM_PITCHES = (
    0.0,
    12.0,
    24.0,
    36.0,
)  # ... and degrees its wrist rises (the pads tilt off the wall: a firm hold needs little)
NEIGHBOUR_MARGIN = 0.01  # m kept between the hand at a grasp and the bounding box of any other object


def turned_rim_grasps(env: RoboLabEnv, name: str, grasp: np.ndarray) -> list[np.ndarray]:
    """The rim grasp `grasp` of lying container `name` (fingers closing vertically on the top of its wall) and the
    same grasp with the hand turned about the vertical through the TCP by RIM_YAWS (the pads stay flat on the wall)
    and its wrist raised by RIM_PITCHES: those whose hand keeps clear of every other object first, then the least
    raised, then the least turned."""
    from robolab_ms.catalog.procedural import quat_to_matrix
    from robolab_ms.policies.oracle import _hand_points, _matrix_to_quaternion, _rotation_about, _world_points

    boxes = []
    for other in env.objects:
        if other != name and not env.eval_context.entries[other].is_fixture:
            points = _world_points(env, other)
            boxes.append((points.min(axis=0) - NEIGHBOUR_MARGIN, points.max(axis=0) + NEIGHBOUR_MARGIN))
    rotation = quat_to_matrix(grasp[3:])
    side = rotation[:, 0] * (1.0 if np.cross(rotation[:, 0], rotation[:, 2])[2] < 0 else -1.0)  # raises the wrist
    found = []
    for pitch_rank, pitch in enumerate(RIM_PITCHES):
        raised = _rotation_about(side, np.radians(pitch)) @ rotation
        for yaw_rank, yaw in enumerate(RIM_YAWS):
            turned = _rotation_about(np.array([0.0, 0.0, 1.0]), np.radians(yaw)) @ raised
            pose = np.concatenate([grasp[:3], _matrix_to_quaternion(turned)])
            hand = _hand_points(pose)
            clash = any(bool(np.any(np.all((hand >= low) & (hand <= high), axis=1))) for low, high in boxes)
            found.append((clash, pitch_rank, yaw_rank, pose))
    return [pose for *_, pose in sorted(found, key=lambda item: item[:3])]
