"""RoboLabEnv: one ManiSkill environment class for every task spec.

The task spec (task_specs/<Task>.yaml) names the scene (scene_builders/<scene>.yaml); the scene is built by
RoboLabSceneBuilder; evaluate() runs the spec's success conditions through the predicate registry and the subtask
state machine. Physics runs at 120 Hz and control at 15 Hz. The robot is chosen at run time (`robot_uids`, default
`droid`, see robolab_ms.agents). Actions follow DROID: absolute arm joint targets (7 for the Panda arms) and one
gripper value (0 open, 1 closed; above 0.5 closes).
"""

from __future__ import annotations

import math
import re
import warnings
from typing import Any

import numpy as np
import sapien
import torch
from gymnasium import spaces
from mani_skill.agents.base_agent import BaseAgent
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import common
from mani_skill.utils.structs.pose import Pose
from mani_skill.utils.structs.types import SimConfig

from robolab_ms.agents import DEFAULT_ROBOT, ROBOT_BINDINGS, robot_binding
from robolab_ms.catalog import load_catalog
from robolab_ms.envs import cameras as cameras_module
from robolab_ms.errors import RoboLabError, UnknownNameError
from robolab_ms.render_check import NO_DEVICE_HELP
from robolab_ms.scene.builder import RoboLabSceneBuilder
from robolab_ms.tasks.context import EvalContext
from robolab_ms.tasks.evaluator import TaskEvaluator
from robolab_ms.tasks.predicates import TABLE
from robolab_ms.tasks.spec import CONTROL_HZ, INSTRUCTION_VARIANTS, load_task

SIM_HZ = 120


class RoboLabEnv(BaseEnv):
    """A RoboLab task in ManiSkill. Registered once per task spec as `RoboLab-<Task>-v1`.

    Args:
        task: task name (the spec file's stem), set by the registration of each id.
        instruction: which instruction variant the episode carries: default, vague or specific.
        robot_uids: the robot, one of `ROBOT_BINDINGS` (default `droid`: Panda + Robotiq 2F-85).
        cameras: the policy cameras, any of external_left, external_right, wrist (default external_left + wrist).
        camera_width, camera_height: their resolution (default 320x180, at most 1280x720).
        video_width, video_height: resolution of the `video` camera that `render()` uses (not an observation).
        Other keyword arguments go to ManiSkill's BaseEnv (obs_mode, render_mode, sim_backend, ...).
    """

    SUPPORTED_ROBOTS = list(ROBOT_BINDINGS)
    SUPPORTED_REWARD_MODES = ("sparse", "none")
    agent: BaseAgent

    def __init__(
        self,
        *args: Any,
        task: str,
        instruction: str = "default",
        robot_uids: str = DEFAULT_ROBOT,
        control_mode: str | None = None,
        cameras: tuple[str, ...] | list[str] = cameras_module.DEFAULT_CAMERAS,
        camera_width: int = 320,
        camera_height: int = 180,
        video_width: int = 640,
        video_height: int = 360,
        **kwargs: Any,
    ) -> None:
        self.task_spec = load_task(task)
        if instruction not in INSTRUCTION_VARIANTS:
            raise UnknownNameError("instruction variant", instruction, INSTRUCTION_VARIANTS)
        self.robot = robot_binding(robot_uids)
        self.instruction_variant = instruction
        self.instruction = self.task_spec.instructions[instruction]
        self.camera_names = cameras_module.check_cameras(cameras, camera_width, camera_height)
        self.camera_width, self.camera_height = camera_width, camera_height
        self.video_size = (video_width, video_height)
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
        mount = self.agent.robot.links_map[self.robot.wrist_mount_link]
        return cameras_module.policy_camera_configs(
            self.camera_names, self.camera_width, self.camera_height, mount, cameras_module.wrist_pose(self.robot)
        )

    @property
    def _default_human_render_camera_configs(self) -> CameraConfig:
        return cameras_module.video_camera_config(*self.video_size)

    def _set_droid_action_space(self) -> None:
        """Replace the gripper's controller range with DROID's [0, 1]."""
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
        with warnings.catch_warnings():
            # ManiSkill's passive joint controller (the Robotiq linkage) declares an empty float64 Box: a harmless cast
            warnings.filterwarnings("ignore", message=r".*Box (low|high)'s precision lowered by casting to float32")
            super()._load_agent(options, self._robot_base_pose())

    def _robot_base_pose(self) -> sapien.Pose:
        yaw = self.robot.base_yaw
        return sapien.Pose(p=[0.0, 0.0, 0.0], q=[math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])

    def _load_scene(self, options: dict) -> None:
        spec = self.task_spec
        self.scene_builder = RoboLabSceneBuilder(self, spec.scene, self.catalog)
        self.scene_builder.build()
        self.objects = self.scene_builder.objects
        entries = {p.name: self.catalog[p.asset] for p in spec.scene.objects}
        entries[TABLE] = self.scene_builder.table_entry
        links = self.agent.robot.links_map
        fingers = [links[name] for name in self.robot.finger_links]
        joints = [joint.name for joint in self.agent.robot.active_joints]
        self._arm_joint_index = torch.tensor([joints.index(j) for j in self.robot.arm_joints], device=self.device)
        self._gripper_joint_index = torch.tensor([joints.index(j) for j in self.robot.gripper_joints], device=self.device)
        home = torch.zeros(len(joints))
        home[self._arm_joint_index.cpu()] = torch.tensor(self.robot.home_arm_qpos, dtype=torch.float32)
        home[self._gripper_joint_index.cpu()] = self.robot.gripper_open_qpos
        self._home_qpos = home.to(self.device)
        actors = {**self.objects, TABLE: self.scene_builder.table}
        self.eval_context = EvalContext(self.scene, actors, entries, fingers, self.device)
        self.task_evaluator = TaskEvaluator(spec, self.eval_context)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict) -> None:
        with torch.device(self.device):
            self.scene_builder.initialize(env_idx)
            count = len(env_idx)
            self.agent.reset(self._home_qpos.repeat(count, 1))
            self.agent.robot.set_pose(Pose.create(self._robot_base_pose()))
            self.task_evaluator.reset(env_idx)

    def gripper_closed_fraction(self) -> torch.Tensor:
        """How far the gripper is closed, 0 open to 1 closed: (num_envs,)."""
        return self.robot.closed_fraction(self.agent.robot.get_qpos()[:, self._gripper_joint_index])

    def arm_qpos(self) -> torch.Tensor:
        """Arm joint positions (rad), gripper excluded: (num_envs, arm joints)."""
        return self.agent.robot.get_qpos()[:, self._arm_joint_index]

    def set_arm_qpos(self, arm_qpos: torch.Tensor | list[float]) -> None:
        """Teleport the arm to these joint positions (rad), for every environment; the gripper stays as it is."""
        qpos = self.agent.robot.get_qpos().clone()
        qpos[:, self._arm_joint_index] = torch.as_tensor(arm_qpos, dtype=qpos.dtype, device=self.device)
        self.agent.robot.set_qpos(qpos)

    def tcp_pose(self) -> Pose:
        """End-effector pose (between the fingertips)."""
        return self.agent.tcp_pose

    # ------------------------------------------------------------------------------------------------ stepping
    def _step_action(self, action: Any) -> Any:
        """Map DROID's gripper value (0 open, 1 closed, > 0.5 closes) to the robot's gripper controller value."""
        if isinstance(action, (np.ndarray, torch.Tensor)):
            action = common.to_tensor(action, device=self.device).clone().float()
            action[..., -1] = self.robot.gripper_action(action[..., -1])
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
        extra = dict(tcp_pose=self.tcp_pose().raw_pose, gripper_position=self.gripper_closed_fraction()[:, None])
        if self.obs_mode_struct.use_state:
            for name, actor in self.objects.items():
                extra[f"{name}_pose"] = actor.pose.raw_pose
        return extra

    def compute_sparse_reward(self, obs: Any, action: torch.Tensor, info: dict) -> torch.Tensor:
        return info["success"].float()
