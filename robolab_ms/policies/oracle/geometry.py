"""Pose and box arithmetic of the oracle, free of any scene: TCP poses are [x, y, z, qw, qx, qy, qz] in the robot
frame, boxes are (rotation (3, 3), centre (3,), half extents (3,))."""

from __future__ import annotations

import numpy as np

from robolab_ms.catalog.procedural import quat_to_matrix

Box = tuple[np.ndarray, np.ndarray, np.ndarray]

__all__ = [
    "Box",
    "down_quaternion",
    "inside_boxes",
    "matrix_to_quaternion",
    "quat_to_matrix",
    "raised",
    "rolled",
    "rotation_about",
    "rotation_between",
    "shifted",
    "turned",
]


def shifted(pose: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """`pose` moved by `offset` (x, y, z), turned the same way."""
    moved = pose.copy()
    moved[:3] += offset
    return moved


def raised(pose: np.ndarray, height: float) -> np.ndarray:
    """`pose` moved up by `height`."""
    return shifted(pose, np.array([0.0, 0.0, height]))


def rolled(pose: np.ndarray) -> np.ndarray:
    """The same TCP pose turned half a turn about the fingers' direction (the fingers swap sides)."""
    turned_pose = pose.copy()
    turned_pose[3:] = matrix_to_quaternion(quat_to_matrix(pose[3:]) @ np.diag([-1.0, -1.0, 1.0]))
    return turned_pose


def turned(direction: np.ndarray, degrees: float) -> np.ndarray:
    """The horizontal direction (x, y) turned by `degrees` about the vertical."""
    angle = np.radians(degrees)
    cos, sin = np.cos(angle), np.sin(angle)
    return np.array([cos * direction[0] - sin * direction[1], sin * direction[0] + cos * direction[1]])


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """The rotation matrix of `angle` rad about `axis`."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle).as_matrix()


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation matrix that turns direction `a` into direction `b`."""
    from scipy.spatial.transform import Rotation

    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    axis = np.cross(a, b)
    sine, cosine = np.linalg.norm(axis), float(np.dot(a, b))
    if sine < 1e-9:
        if cosine > 0:
            return np.eye(3)
        other = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        axis = np.cross(a, other)
        return Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.pi).as_matrix()
    return Rotation.from_rotvec(axis / sine * np.arctan2(sine, cosine)).as_matrix()


def matrix_to_quaternion(rotation: np.ndarray) -> np.ndarray:
    """The quaternion (w, x, y, z) of a rotation matrix."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    return np.array([w, x, y, z])


def down_quaternion(closing_direction: np.ndarray, keep_sign: bool = False) -> np.ndarray:
    """Quaternion (w, x, y, z) of a TCP pointing down (its z = world -z) with its y axis (the fingers' closing
    direction) along `closing_direction` in the table plane; unless `keep_sign`, of the two ways round the one
    whose x axis points away from the robot."""
    y = np.array([closing_direction[0], closing_direction[1], 0.0])
    y /= np.linalg.norm(y)
    z = np.array([0.0, 0.0, -1.0])
    x = np.cross(y, z)
    if x[0] < 0 and not keep_sign:  # the hand's x away from the robot: the wrist does not have to turn around
        x, y = -x, -y
    return matrix_to_quaternion(np.stack([x, y, z], axis=1))


def in_frame(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """World `points` (N, 3) in the frame of `pose` [x, y, z, qw, qx, qy, qz]."""
    return (points - pose[:3]) @ quat_to_matrix(pose[3:])


def boxes_overlap(first: Box, second: Box, margin: float) -> bool:
    """Whether two boxes come within `margin` of each other (the first grown by it on every side): no axis of
    either, nor a cross product of one axis of each, separates them."""
    (rotation_a, centre_a, half_a), (rotation_b, centre_b, half_b) = first, second
    half_a = half_a + margin
    axes = [*rotation_a.T, *rotation_b.T]
    axes += [np.cross(u, v) for u in rotation_a.T for v in rotation_b.T]
    between = centre_b - centre_a
    for axis in axes:
        if float(axis @ axis) < 1e-12:  # parallel edges: covered by the boxes' own axes
            continue
        reach = np.abs(rotation_a.T @ axis) @ half_a + np.abs(rotation_b.T @ axis) @ half_b
        if abs(float(between @ axis)) > reach:
            return False
    return True


def inside_boxes(points: np.ndarray, boxes: list[Box], margin: float) -> bool:
    """Whether any of the world `points` (N, 3) lies within `margin` of one of the `boxes`."""
    middle = points.mean(axis=0)
    radius = float(np.sqrt(((points - middle) ** 2).sum(axis=1).max()))  # the points lie in this ball
    for rotation, centre, half in boxes:
        if float(np.linalg.norm(middle - centre)) > radius + float(np.linalg.norm(half + margin)):
            continue  # the ball round the points misses the ball round the grown box
        if np.any(np.all(np.abs((points - centre) @ rotation) <= half + margin, axis=1)):
            return True
    return False
