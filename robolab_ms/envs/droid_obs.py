"""DROID-style observations for policy clients, so they never read ManiSkill's nested observation dict.

    env = DroidObservation(gym.make("RoboLab-BananaInBowl-v1", obs_mode="rgb"))
    obs, info = env.reset(seed=0)
    obs["exterior_image_1_left"]  # (num_envs, H, W, 3) uint8
    obs["prompt"]                 # the task instruction, one string

Every array keeps ManiSkill's leading num_envs dimension, also for num_envs = 1 (nothing is squeezed), and is a
NumPy array on the CPU. With `images=False` the two image keys are left out and the environment may be made with
state observations (nothing is rendered), for policies that read only the robot's state.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from robolab_ms.errors import RoboLabError

EXTERIOR_IMAGE = "exterior_image_1_left"
WRIST_IMAGE = "wrist_image_left"


class DroidObservation(gym.ObservationWrapper):
    """Observations as DROID names them: two images, arm joints, gripper position, end-effector pose, prompt.

    Keys: `exterior_image_1_left` and `wrist_image_left` (E, H, W, 3) uint8; `joint_position` (E, arm joints)
    float32 rad; `gripper_position` (E, 1) float32, 0 open to 1 closed; `eef_pose` (E, 7) float32, position (m)
    and quaternion (w, x, y, z) in the robot base frame; `prompt` str, the instruction.

    Args:
        env: a RoboLab environment made with obs_mode "rgb" (or another mode with rgb images); any mode when
            `images` is False.
        exterior_camera: which external camera feeds `exterior_image_1_left` (external_left by default).
        images: whether to include the two images (False: the robot's state and the prompt only).
    """

    def __init__(self, env: gym.Env, exterior_camera: str = "external_left", images: bool = True) -> None:
        super().__init__(env)
        base = env.unwrapped
        self.exterior_camera, self.images = exterior_camera, images
        count, arm = base.num_envs, len(base.robot.arm_joints)
        keys: dict[str, spaces.Space] = {}
        if images:
            cameras = getattr(base, "camera_names", ())
            for needed in (exterior_camera, "wrist"):
                if needed not in cameras:
                    raise RoboLabError(
                        f"DroidObservation needs the '{needed}' camera; make the environment with "
                        f"cameras=({exterior_camera!r}, 'wrist') (it has {list(cameras)})"
                    )
            if "rgb" not in getattr(base, "obs_mode", ""):
                raise RoboLabError(
                    f"DroidObservation needs images: make the environment with obs_mode='rgb' "
                    f"(it has '{base.obs_mode}'), or pass images=False"
                )
            image = spaces.Box(0, 255, (count, base.camera_height, base.camera_width, 3), np.uint8)
            keys = {EXTERIOR_IMAGE: image, WRIST_IMAGE: image}
        self.observation_space = spaces.Dict(
            {
                **keys,
                "joint_position": spaces.Box(-np.inf, np.inf, (count, arm), np.float32),
                "gripper_position": spaces.Box(0.0, 1.0, (count, 1), np.float32),
                "eef_pose": spaces.Box(-np.inf, np.inf, (count, 7), np.float32),
                "prompt": spaces.Text(max_length=1000),
            }
        )

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        base = self.env.unwrapped
        images = {}
        if self.images:
            sensors = observation["sensor_data"]
            images = {
                EXTERIOR_IMAGE: _numpy(sensors[self.exterior_camera]["rgb"]),
                WRIST_IMAGE: _numpy(sensors["wrist"]["rgb"]),
            }
        return {
            **images,
            "joint_position": _numpy(base.arm_qpos()).astype(np.float32),
            "gripper_position": _numpy(observation["extra"]["gripper_position"]).astype(np.float32),
            "eef_pose": _numpy(observation["extra"]["tcp_pose"]).astype(np.float32),
            "prompt": base.instruction,
        }


def _numpy(tensor: Any) -> np.ndarray:
    return tensor.detach().cpu().numpy() if hasattr(tensor, "detach") else np.asarray(tensor)
