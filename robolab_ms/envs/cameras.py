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

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sapien
import torch
from mani_skill.render.shaders import PREBUILT_SHADER_CONFIGS, ShaderConfig
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
    names: Sequence[str], width: int, height: int, wrist_mount, wrist_pose: sapien.Pose, render_quality: str = "fast"
) -> list[CameraConfig]:
    """ManiSkill camera configs for the policy cameras `names` (any of POLICY_CAMERAS)."""
    shader = dict(shader_config=shader_config(render_quality))
    configs = []
    for name in names:
        if name == "wrist":
            intrinsic = scaled_intrinsic(WRIST_FOCAL_NATIVE, width, height)
            configs.append(
                CameraConfig(
                    name,
                    wrist_pose,
                    width,
                    height,
                    intrinsic=intrinsic,
                    near=0.01,
                    far=FAR,
                    mount=wrist_mount,
                    **shader,
                )
            )
        else:
            intrinsic = scaled_intrinsic(EXTERNAL_FOCAL_NATIVE, width, height)
            pose = external_pose(name.removeprefix("external_"))
            configs.append(CameraConfig(name, pose, width, height, intrinsic=intrinsic, near=0.01, far=FAR, **shader))
    return configs


def video_camera_config(width: int, height: int, render_quality: str = "fast") -> CameraConfig:
    """A wide third-person view for recordings (`env.render()`); never part of the observations."""
    pose = sapien_utils.look_at(eye=[1.45, 0.85, 0.85], target=[0.45, 0.0, 0.1])
    return CameraConfig(
        "video",
        pose,
        width,
        height,
        fov=math.radians(60),
        near=0.01,
        far=FAR,
        shader_config=shader_config(render_quality),
    )


# ---------------------------------------------------------------------------------------------------- render quality
FAR = 20.0  # m: the room's panorama is 7.5 m from the table
# fast: SAPIEN's rasteriser (its single-pass shader: textures, shadow maps, environment light); high: its ray tracer
# with ManiSkill's `rt` settings (32 samples per pixel, path depth 16), denoised with OIDN: OptiX, ManiSkill's choice,
# failed on an H100 tried here and returned black frames. The room, lights and materials are the same for both.
SHADER_PACKS = {"fast": "minimal", "high": "rt"}
RENDER_QUALITIES = tuple(SHADER_PACKS)
HIGH_DENOISER = "oidn"


def shader_config(quality: str) -> ShaderConfig:
    """ManiSkill's shader settings for a render quality."""
    config = copy.deepcopy(PREBUILT_SHADER_CONFIGS[SHADER_PACKS[check_render_quality(quality)]])
    if quality == "high":
        config.shader_pack_config["ray_tracing_denoiser"] = HIGH_DENOISER
    return config


def check_render_quality(quality: str) -> str:
    """`quality` if it names a render quality (fast or high), else a clear error."""
    if quality not in SHADER_PACKS:
        raise UnknownNameError("render quality", quality, RENDER_QUALITIES)
    return quality


# ---------------------------------------------------------------------------------------------------- sensor effects
@dataclass(frozen=True)
class SensorEffects:
    """What a real camera adds to an image, applied to the policy cameras' RGB (the `video` camera stays clean).

    exposure: brightness gain; white_balance: per-channel (R, G, B) gains; blur: Gaussian blur sigma in pixels at
    the camera's resolution; noise: standard deviation of Gaussian noise in 8-bit levels. The defaults change
    nothing. Noise is drawn from a generator seeded by the episode's seed and step, so episodes replay exactly.
    """

    exposure: float = 1.0
    white_balance: tuple[float, float, float] = (1.0, 1.0, 1.0)
    blur: float = 0.0
    noise: float = 0.0

    def __post_init__(self) -> None:
        if not (0.0 < self.exposure <= 8.0):
            raise ValueError(f"sensor effects: exposure must be in (0, 8], got {self.exposure}")
        if len(self.white_balance) != 3 or not all(0.0 < g <= 4.0 for g in self.white_balance):
            raise ValueError(f"sensor effects: white_balance must be three gains in (0, 4], got {self.white_balance}")
        if not (0.0 <= self.blur <= 10.0):
            raise ValueError(f"sensor effects: blur must be a sigma in [0, 10] px, got {self.blur}")
        if not (0.0 <= self.noise <= 64.0):
            raise ValueError(f"sensor effects: noise must be in [0, 64] 8-bit levels, got {self.noise}")

    @classmethod
    def create(cls, value: SensorEffects | dict | None) -> SensorEffects:
        """From an instance, a dict of its fields, or None (no effects)."""
        if value is None:
            return cls()
        if isinstance(value, cls):
            return value
        unknown = set(value) - {"exposure", "white_balance", "blur", "noise"}
        if unknown:
            raise ValueError(
                f"sensor effects: unknown field(s) {sorted(unknown)}; use exposure, white_balance, blur, noise"
            )
        return cls(**{k: tuple(v) if k == "white_balance" else float(v) for k, v in value.items()})

    @property
    def active(self) -> bool:
        return self != SensorEffects()

    def apply(self, rgb: torch.Tensor, seed: int, step: int) -> torch.Tensor:
        """The image batch (E, H, W, 3) uint8 with the effects applied."""
        if not self.active:
            return rgb
        image = rgb.float()
        if self.exposure != 1.0 or tuple(self.white_balance) != (1.0, 1.0, 1.0):  # a gain of 1 changes nothing
            gains = torch.tensor(self.white_balance, dtype=image.dtype, device=image.device) * self.exposure
            image = image * gains
        if self.blur > 0:
            image = _gaussian_blur(image, self.blur)
        if self.noise > 0:
            generator = torch.Generator(device="cpu").manual_seed((seed * 1_000_003 + step) % (2**63))
            image.add_(torch.randn(image.shape, generator=generator).to(image.device).mul_(self.noise))
        return image.round_().clamp_(0, 255).to(torch.uint8)


def _gaussian_blur(image: torch.Tensor, sigma: float) -> torch.Tensor:
    """Separable Gaussian blur of (E, H, W, C) float images."""
    radius = max(1, int(math.ceil(3 * sigma)))
    x = torch.arange(-radius, radius + 1, dtype=image.dtype, device=image.device)
    kernel = torch.exp(-(x**2) / (2 * sigma**2))
    kernel = kernel / kernel.sum()
    channels = image.shape[-1]
    data = image.permute(0, 3, 1, 2)  # E, C, H, W
    data = torch.nn.functional.pad(data, (radius, radius, radius, radius), mode="replicate")
    horizontal = kernel.view(1, 1, 1, -1).repeat(channels, 1, 1, 1)
    vertical = kernel.view(1, 1, -1, 1).repeat(channels, 1, 1, 1)
    data = torch.nn.functional.conv2d(data, horizontal, groups=channels)
    data = torch.nn.functional.conv2d(data, vertical, groups=channels)
    return data.permute(0, 2, 3, 1)
