"""DROID's cameras in ManiSkill: two external cameras over the shoulders, one on the wrist, and a video camera.

Poses and focal lengths are DROID's (FACTS section 2), given there as quaternions in the OpenGL camera convention
(looking along -z, y up); SAPIEN's cameras look along +x with z up, so `opengl_to_sapien` converts. The wrist pose
is given in a gripper frame whose x axis points along the fingers; ours points z along the fingers, and
`DROID_GRIPPER_TO_OURS` maps one to the other (the camera sits on the side of the gripper that faces away from
the robot at the home pose, its image up pointing away from the fingers, so the fingers show at the bottom).
Focal lengths are defined at 1280x720 and scale with the chosen resolution, so the field of view stays
104 deg (external) and 87.7 deg (wrist) at any size.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import sapien
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import sapien_utils
from transforms3d.quaternions import mat2quat, quat2mat

from robolab_ms.agents.bindings import RobotBinding
from robolab_ms.errors import UnknownNameError

NATIVE_WIDTH, NATIVE_HEIGHT = 1280, 720
EXTERNAL_FOCAL_NATIVE = 500.0  # px at 1280x720: horizontal field of view 104 deg
WRIST_FOCAL_NATIVE = 666.7  # px at 1280x720: 87.7 deg
EXTERNAL_LEFT_POSITION = (0.05, 0.57, 0.66)
EXTERNAL_LEFT_QUAT_OPENGL = (-0.393, -0.195, 0.399, 0.805)  # (w, x, y, z), world frame
WRIST_OFFSET_DROID = (0.011, -0.031, -0.074)  # m, in DROID's gripper frame
WRIST_QUAT_OPENGL = (-0.420, 0.570, 0.576, -0.409)
# columns: DROID gripper frame axes (x along the fingers) expressed in our gripper base frame (z along the fingers)
DROID_GRIPPER_TO_OURS = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
MIRROR_Y = np.diag([1.0, -1.0, 1.0])

POLICY_CAMERAS = ("external_left", "external_right", "wrist")
DEFAULT_CAMERAS = ("external_left", "wrist")  # DROID's default policy view
MAX_WIDTH, MAX_HEIGHT = NATIVE_WIDTH, NATIVE_HEIGHT


def opengl_to_sapien(quat_wxyz: Sequence[float]) -> np.ndarray:
    """Rotation (3, 3) of a SAPIEN camera (x forward, y left, z up) from an OpenGL-convention quaternion."""
    gl = quat2mat(np.asarray(quat_wxyz, dtype=float))
    forward, left, up = -gl[:, 2], -gl[:, 0], gl[:, 1]
    return np.stack([forward, left, up], axis=1)


def _pose(position: Sequence[float], rotation: np.ndarray) -> sapien.Pose:
    return sapien.Pose(p=np.asarray(position, dtype=float), q=mat2quat(rotation))


def external_pose(side: str) -> sapien.Pose:
    """World pose of DROID's external camera on the robot's `left` or `right` (mirrored across the xz plane)."""
    rotation = opengl_to_sapien(EXTERNAL_LEFT_QUAT_OPENGL)
    position = np.asarray(EXTERNAL_LEFT_POSITION)
    if side == "right":
        rotation, position = MIRROR_Y @ rotation @ MIRROR_Y, MIRROR_Y @ position
    return _pose(position, rotation)


def droid_wrist_pose() -> sapien.Pose:
    """Pose of DROID's wrist camera in the Robotiq gripper base frame."""
    rotation = DROID_GRIPPER_TO_OURS @ opengl_to_sapien(WRIST_QUAT_OPENGL)
    return _pose(DROID_GRIPPER_TO_OURS @ np.asarray(WRIST_OFFSET_DROID), rotation)


def wrist_pose(robot: RobotBinding) -> sapien.Pose:
    """The wrist camera's pose in the robot's wrist mount link."""
    if robot.wrist_look_at is None:
        return droid_wrist_pose()
    eye, target, up = robot.wrist_look_at
    return sapien_utils.look_at(eye=list(eye), target=list(target), up=list(up)).sp


def scaled_intrinsic(focal_native: float, width: int, height: int) -> np.ndarray:
    """A pinhole matrix with DROID's native focal length scaled to width x height."""
    fx = focal_native * width / NATIVE_WIDTH
    fy = focal_native * height / NATIVE_HEIGHT
    return np.array([[fx, 0.0, width / 2], [0.0, fy, height / 2], [0.0, 0.0, 1.0]])


def check_cameras(names: Sequence[str], width: int, height: int) -> tuple[str, ...]:
    """Validate the requested policy cameras and resolution; returns the names as a tuple."""
    for name in names:
        if name not in POLICY_CAMERAS:
            raise UnknownNameError("camera", name, POLICY_CAMERAS)
    if not (16 <= width <= MAX_WIDTH and 16 <= height <= MAX_HEIGHT):
        raise ValueError(f"camera resolution {width}x{height} is outside 16x16 .. {MAX_WIDTH}x{MAX_HEIGHT}")
    return tuple(names)


def policy_camera_configs(
    names: Sequence[str], width: int, height: int, wrist_mount, wrist_pose: sapien.Pose
) -> list[CameraConfig]:
    """ManiSkill camera configs for the policy cameras `names` (any of POLICY_CAMERAS)."""
    configs = []
    for name in names:
        if name == "wrist":
            intrinsic = scaled_intrinsic(WRIST_FOCAL_NATIVE, width, height)
            configs.append(CameraConfig(name, wrist_pose, width, height, intrinsic=intrinsic, near=0.01, far=10,
                                        mount=wrist_mount))  # fmt: skip
        else:
            intrinsic = scaled_intrinsic(EXTERNAL_FOCAL_NATIVE, width, height)
            pose = external_pose(name.removeprefix("external_"))
            configs.append(CameraConfig(name, pose, width, height, intrinsic=intrinsic, near=0.01, far=10))
    return configs


def video_camera_config(width: int, height: int) -> CameraConfig:
    """A wide third-person view for recordings (`env.render()`); never part of the observations."""
    pose = sapien_utils.look_at(eye=[1.45, 0.85, 0.85], target=[0.45, 0.0, 0.1])
    return CameraConfig("video", pose, width, height, fov=math.radians(60), near=0.01, far=10)
