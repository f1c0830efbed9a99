"""RoboLabEnv: one ManiSkill environment class for every task spec.

The task spec (task_specs/<Task>.yaml) names the scene (scene_builders/<scene>.yaml); the scene is built by
RoboLabSceneBuilder; evaluate() runs the spec's success conditions through the predicate registry and the subtask
state machine. Physics runs at 120 Hz and control at 15 Hz. Actions follow DROID: 7 absolute arm joint targets and
one gripper value (0 open, 1 closed; above 0.5 closes).
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import sapien
import torch
from gymnasium import spaces
from mani_skill.agents.robots import Panda
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import common, sapien_utils
from mani_skill.utils.structs.pose import Pose
from mani_skill.utils.structs.types import SimConfig

from robolab_ms.catalog import load_catalog
from robolab_ms.errors import RoboLabError, UnknownNameError
from robolab_ms.render_check import NO_DEVICE_HELP
from robolab_ms.scene.builder import RoboLabSceneBuilder
from robolab_ms.tasks.context import EvalContext
from robolab_ms.tasks.evaluator import TaskEvaluator
from robolab_ms.tasks.predicates import TABLE
from robolab_ms.tasks.spec import CONTROL_HZ, INSTRUCTION_VARIANTS, load_task

SIM_HZ = 120
HOME_ARM_QPOS = [0.0, -math.pi / 5, 0.0, -4 * math.pi / 5, 0.0, 3 * math.pi / 5, 0.0]  # DROID home
PANDA_FINGER_OPEN = 0.04  # finger joint position (m) of a fully open Panda gripper
NATIVE_WIDTH, NATIVE_HEIGHT = 1280, 720
EXTERNAL_FOCAL_NATIVE = 500.0  # px at 1280x720 (horizontal field of view 104 deg)
WRIST_FOCAL_NATIVE = 666.7  # px at 1280x720 (87.7 deg)
EXTERNAL_LEFT_EYE = [0.05, 0.57, 0.66]
EXTERNAL_LEFT_TARGET = [0.55, -0.12, 0.0]


def scaled_intrinsic(focal_native: float, width: int, height: int) -> np.ndarray:
    """A pinhole matrix with DROID's native focal length scaled to width x height."""
    fx = focal_native * width / NATIVE_WIDTH
    fy = focal_native * height / NATIVE_HEIGHT
    return np.array([[fx, 0.0, width / 2], [0.0, fy, height / 2], [0.0, 0.0, 1.0]])


class RoboLabEnv(BaseEnv):
    """A RoboLab task in ManiSkill. Registered once per task spec as `RoboLab-<Task>-v1`.

    Args:
        task: task name (the spec file's stem), set by the registration of each id.
        instruction: which instruction variant the episode carries: default, vague or specific.
        camera_width, camera_height: resolution of the two policy cameras (default 320x180).
        Other keyword arguments go to ManiSkill's BaseEnv (obs_mode, render_mode, sim_backend, ...).
    """

    SUPPORTED_ROBOTS = ["panda"]
    SUPPORTED_REWARD_MODES = ("sparse", "none")
    agent: Panda

    def __init__(
        self,
        *args: Any,
        task: str,
        instruction: str = "default",
        robot_uids: str = "panda",
        control_mode: str | None = None,
        camera_width: int = 320,
        camera_height: int = 180,
        **kwargs: Any,
    ) -> None:
        self.task_spec = load_task(task)
        if instruction not in INSTRUCTION_VARIANTS:
            raise UnknownNameError("instruction variant", instruction, INSTRUCTION_VARIANTS)
        self.instruction_variant = instruction
        self.instruction = self.task_spec.instructions[instruction]
        self.camera_width, self.camera_height = camera_width, camera_height
        self.catalog = load_catalog()
        if kwargs.get("render_backend", "gpu") == "gpu" and not torch.cuda.is_available():
            kwargs["render_backend"] = "cpu"  # what ManiSkill falls back to anyway, without its warning
        try:
            super().__init__(*args, robot_uids=robot_uids, control_mode=control_mode or "pd_joint_pos", **kwargs)
        except RuntimeError as error:
            if re.search(r"vk::|vulkan|rendering device", str(error), re.IGNORECASE):
                raise RoboLabError(f"SAPIEN found no rendering device ({error}). {NO_DEVICE_HELP}") from None
            raise
        self._set_droid_action_space()

    # ------------------------------------------------------------------------------------------------ configuration
    @property
    def _default_sim_config(self) -> SimConfig:
        return SimConfig(sim_freq=SIM_HZ, control_freq=CONTROL_HZ)

    @property
    def _default_sensor_configs(self) -> list[CameraConfig]:
        width, height = self.camera_width, self.camera_height
        external = sapien_utils.look_at(eye=EXTERNAL_LEFT_EYE, target=EXTERNAL_LEFT_TARGET)
        # Wrist camera on the hand, a little off the gripper axis, looking along the fingers (hand +z).
        wrist = sapien_utils.look_at(eye=[0.06, 0.0, 0.0], target=[0.0, 0.0, 0.2], up=[1.0, 0.0, 0.0])
        return [
            CameraConfig("external_left", external, width, height,
                         intrinsic=scaled_intrinsic(EXTERNAL_FOCAL_NATIVE, width, height), near=0.01, far=10),
            CameraConfig("wrist", wrist, width, height, intrinsic=scaled_intrinsic(WRIST_FOCAL_NATIVE, width, height),
                         near=0.01, far=10, mount=self.agent.robot.links_map["panda_hand"]),
        ]  # fmt: skip

    @property
    def _default_human_render_camera_configs(self) -> CameraConfig:
        pose = sapien_utils.look_at(eye=[1.5, 0.9, 0.8], target=[0.45, 0.0, 0.05])
        return CameraConfig("render_camera", pose, 640, 480, fov=math.radians(55), near=0.01, far=10)

    def _set_droid_action_space(self) -> None:
        """Replace the gripper's [-1, 1] range of the ManiSkill controller with DROID's [0, 1]."""
        low = self.single_action_space.low.copy()
        high = self.single_action_space.high.copy()
        low[-1], high[-1] = 0.0, 1.0
        self.single_action_space = spaces.Box(low, high, dtype=np.float32)
        self.action_space = spaces.Box(
            np.tile(low, (self.num_envs, 1)), np.tile(high, (self.num_envs, 1)), dtype=np.float32
        )
        self._orig_single_action_space = self.single_action_space

    # ------------------------------------------------------------------------------------------------ lifecycle
    def _load_agent(self, options: dict) -> None:
        super()._load_agent(options, sapien.Pose(p=[0.0, 0.0, 0.0]))

    def _load_scene(self, options: dict) -> None:
        spec = self.task_spec
        self.scene_builder = RoboLabSceneBuilder(self, spec.scene, self.catalog)
        self.scene_builder.build()
        self.objects = self.scene_builder.objects
        entries = {p.name: self.catalog[p.asset] for p in spec.scene.objects}
        entries[TABLE] = self.scene_builder.table_entry
        fingers = [self.agent.finger1_link, self.agent.finger2_link]
        actors = {**self.objects, TABLE: self.scene_builder.table}
        self.eval_context = EvalContext(self.scene, actors, entries, fingers, self.device)
        self.task_evaluator = TaskEvaluator(spec, self.eval_context)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict) -> None:
        with torch.device(self.device):
            self.scene_builder.initialize(env_idx)
            count = len(env_idx)
            qpos = torch.tensor([*HOME_ARM_QPOS, PANDA_FINGER_OPEN, PANDA_FINGER_OPEN]).repeat(count, 1)
            self.agent.reset(qpos)
            self.agent.robot.set_pose(Pose.create_from_pq(torch.zeros((count, 3))))
            self.task_evaluator.reset(env_idx)

    def gripper_closed_fraction(self) -> torch.Tensor:
        """How far the gripper is closed, 0 open to 1 closed: (num_envs,)."""
        fingers = self.agent.robot.get_qpos()[:, -2:].mean(dim=1)
        return (1.0 - fingers / PANDA_FINGER_OPEN).clamp(0.0, 1.0)

    # ------------------------------------------------------------------------------------------------ stepping
    def _step_action(self, action: Any) -> Any:
        """Map DROID's gripper value (0 open, 1 closed, > 0.5 closes) to the controller's (+1 open, -1 closed)."""
        if isinstance(action, (np.ndarray, torch.Tensor)):
            action = common.to_tensor(action, device=self.device).clone().float()
            action[..., -1] = torch.where(action[..., -1] > 0.5, -1.0, 1.0)
        return super()._step_action(action)

    def evaluate(self) -> dict[str, torch.Tensor]:
        """Success (any success condition holds), score in [0, 1], subtask progress and stage, and which events
        fired this step (`event_<type>`), for every environment."""
        return self.task_evaluator.evaluate(self.elapsed_steps, self.gripper_closed_fraction())

    def get_info(self) -> dict[str, Any]:
        info = super().get_info()
        info["task"] = self.task_spec.name
        info["instruction"] = self.instruction
        info["events"] = self.task_evaluator.events.log  # per environment: every event so far, {step, type, object}
        return info

    def _get_obs_extra(self, info: dict) -> dict[str, torch.Tensor]:
        extra = dict(tcp_pose=self.agent.tcp.pose.raw_pose, gripper_position=self.gripper_closed_fraction()[:, None])
        if self.obs_mode_struct.use_state:
            for name, actor in self.objects.items():
                extra[f"{name}_pose"] = actor.pose.raw_pose
        return extra

    def compute_sparse_reward(self, obs: Any, action: torch.Tensor, info: dict) -> torch.Tensor:
        return info["success"].float()
