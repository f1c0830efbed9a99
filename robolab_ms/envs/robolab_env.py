"""RoboLabEnv: one ManiSkill environment class for every task spec.

The task spec (task_specs/<Task>.yaml) names the scene (scene_builders/<scene>.yaml); the scene is built by
RoboLabSceneBuilder; evaluate() runs the spec's success conditions through the predicate registry and the subtask
state machine. Physics runs at 120 Hz and control at 15 Hz. The robot is chosen at run time (`robot_uids`, default
`droid`, see robolab_ms.agents). Actions follow DROID: absolute arm joint targets (7 for the Panda arms) and one
gripper value (0 open, 1 closed; above 0.5 closes).

Determinism (CPU simulator, one environment per process): an episode is a pure function of (task, instruction
variant, robot, policy, seed). PhysX keeps state that no SAPIEN call reads or writes (persistent contact manifolds,
friction anchors, articulation joint accelerations), so two things are done:
- every reset rebuilds the simulation scene (ManiSkill's reconfiguration, `reconfiguration_freq=1`), so an episode
  starts from a brand-new PhysX scene whatever ran before it in this process;
- the state dict carries the episode's identity (`episode`: seed and step), and the environment keeps the actions of
  its current episode; `set_state_dict` of a state of that episode rebuilds the scene and replays those actions,
  which recreates PhysX's hidden state exactly. Any other state is set the way ManiSkill sets it (poses, velocities,
  joint positions and velocities), and what follows is then close but not guaranteed bit-identical.
"""

from __future__ import annotations

import gc
import math
import re
import warnings
from pathlib import Path
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

from robolab_ms.agents.bindings import DEFAULT_ROBOT, ROBOT_BINDINGS, robot_binding
from robolab_ms.catalog import load_catalog
from robolab_ms.catalog.appearance import scene_renders
from robolab_ms.envs import cameras as cameras_module
from robolab_ms.errors import RoboLabError, UnknownNameError
from robolab_ms.physics import SIM_HZ
from robolab_ms.render_check import NO_DEVICE_HELP
from robolab_ms.tasks.context import EvalContext
from robolab_ms.tasks.evaluator import TaskEvaluator
from robolab_ms.tasks.predicates import TABLE
from robolab_ms.tasks.spec import CONTROL_HZ, INSTRUCTION_VARIANTS, load_task

# The droid agent and the scene builder bring ManiSkill up when imported, and ManiSkill's start-up hook registers the
# environments (imports this module) the moment it is up: they are imported where they are used, so that this
# module never needs one of them while it is still being imported.
CPU_BACKENDS = ("auto", "cpu", "physx_cpu")
STATE_OBS_MODES = ("state", "state_dict", "none")  # observation modes that need no renderer
EPISODE_STATE_KEY = "episode"  # the state dict's entry with the episode's seed and step (see set_state_dict)


class RoboLabEnv(BaseEnv):
    """A RoboLab task in ManiSkill. Registered once per task spec as `RoboLab-<Task>-v1`.

    Args:
        task: the task: a name, an environment id or a task file path (its scene is found next to it or by
            name). Each id's registration sets its own file; everything (episode length included) comes from it.
        instruction: which instruction variant the episode carries: default, vague or specific.
        robot_uids: the robot, one of `ROBOT_BINDINGS` (default `droid`: Panda + Robotiq 2F-85).
        cameras: the policy cameras, any of external_left, external_right, wrist (default external_left + wrist).
        camera_width, camera_height: their resolution (default 320x180, at most 1280x720).
        video_width, video_height: resolution of the `video` camera that `render()` uses (not an observation).
        render_quality: `fast` (rasterised, shadow maps; the default) or `high` (SAPIEN's ray tracer, for GPUs).
        sensor_effects: exposure, white balance, blur and noise of the policy cameras
            (`robolab_ms.envs.cameras.SensorEffects` or a dict of its fields; default: none).
        variations: domain randomization drawn from each episode's seed (`robolab_ms.variations`): text such as
            "lighting,objects=0.2", a dict, or a Variations; default none (the scene exactly as its file says).
            One environment per process (num_envs=1); the scene is rebuilt at every reset.
        Other keyword arguments go to ManiSkill's BaseEnv (obs_mode, render_mode, sim_backend, ...).
    """

    SUPPORTED_ROBOTS = list(ROBOT_BINDINGS)
    SUPPORTED_REWARD_MODES = ("sparse", "none")
    agent: BaseAgent

    def __init__(
        self,
        *args: Any,
        task: str | Path,
        instruction: str = "default",
        robot_uids: str = DEFAULT_ROBOT,
        control_mode: str | None = None,
        cameras: tuple[str, ...] | list[str] = cameras_module.DEFAULT_CAMERAS,
        camera_width: int = 320,
        camera_height: int = 180,
        video_width: int = 640,
        video_height: int = 360,
        render_quality: str = "fast",
        sensor_effects: cameras_module.SensorEffects | dict | None = None,
        variations: Any = None,
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
        self.render_quality = cameras_module.check_render_quality(render_quality)
        self.sensor_effects = cameras_module.SensorEffects.create(sensor_effects)
        self.catalog = load_catalog()
        self._setup_variations(variations, kwargs)
        self._exact_episodes = kwargs.get("num_envs", 1) == 1 and kwargs.get("sim_backend", "auto") in CPU_BACKENDS
        if self._exact_episodes:
            kwargs.setdefault("reconfiguration_freq", 1)  # a brand-new PhysX scene for every episode
            # Each rebuild ends in ManiSkill's full garbage collection, which would scan every object the process
            # holds (torch, SAPIEN, ManiSkill: about 300k, a second per reset here); objects alive now are kept
            # for good anyway, so move them out of the collector's sight.
            gc.freeze()
        self._episode_actions: list[torch.Tensor] = []  # the current episode's actions, for exact state restores
        self._episode_seed_used: int | None = None  # the seed of the current episode; None when not replayable
        self._replaying = False
        self._episode_options: dict = {}
        self.track_events = True  # from the next reset on; False: no events (`robolab validate`'s random episodes)
        _check_renderer_use(kwargs)
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
        configs = cameras_module.policy_camera_configs(
            self.camera_names,
            self.camera_width,
            self.camera_height,
            mount,
            cameras_module.wrist_pose(self.robot),
            self.render_quality,
        )
        return configs if self.variation is None else self.variation.camera_configs(configs)

    @property
    def _default_human_render_camera_configs(self) -> CameraConfig:
        return cameras_module.video_camera_config(*self.video_size, self.render_quality)

    def _load_lighting(self, options: dict) -> None:
        self.scene_builder.build_lighting()  # the room's key light with shadows, instead of ManiSkill's default

    def _get_obs_sensor_data(self, apply_texture_transforms: bool = True) -> dict:
        data = super()._get_obs_sensor_data(apply_texture_transforms)
        if self.sensor_effects.active:
            seed, step = int(self._episode_seed[0]), int(self._elapsed_steps[0])
            for name in self.camera_names:
                if "rgb" in data.get(name, {}):
                    data[name]["rgb"] = self.sensor_effects.apply(data[name]["rgb"], seed, step)
        return data

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
        import robolab_ms.agents.droid  # noqa: F401  (registers the droid agent with ManiSkill; see the note above)

        with warnings.catch_warnings():
            # ManiSkill's passive joint controller (the Robotiq linkage) declares an empty float64 Box: a harmless cast
            warnings.filterwarnings("ignore", message=r".*Box (low|high)'s precision lowered by casting to float32")
            super()._load_agent(options, self._robot_base_pose())

    def _robot_base_pose(self) -> sapien.Pose:
        yaw = self.robot.base_yaw
        return sapien.Pose(p=[0.0, 0.0, 0.0], q=[math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])

    def _load_scene(self, options: dict) -> None:
        from robolab_ms.scene.builder import RoboLabSceneBuilder  # see the note above

        spec = self.task_spec
        self.scene_builder = RoboLabSceneBuilder(self, spec.scene, self.catalog)
        self._draw_variation()
        if self.variation is not None:
            self.variation.configure_builder(self.scene_builder)
        self.scene_builder.build()
        if self.variation is not None:
            self.variation.after_build(self.scene_builder)
        self.objects = self.scene_builder.objects
        entries = {p.name: self.catalog[p.asset] for p in spec.scene.objects}
        entries[TABLE] = self.scene_builder.table_entry
        links = self.agent.robot.links_map
        fingers = [links[name] for name in self.robot.finger_links]
        joints = [joint.name for joint in self.agent.robot.active_joints]
        self._arm_joint_index = torch.tensor([joints.index(j) for j in self.robot.arm_joints], device=self.device)
        self._gripper_joint_index = torch.tensor(
            [joints.index(j) for j in self.robot.gripper_joints], device=self.device
        )
        home = torch.zeros(len(joints))
        home[self._arm_joint_index.cpu()] = torch.tensor(self.robot.home_arm_qpos, dtype=torch.float32)
        home[self._gripper_joint_index.cpu()] = self.robot.gripper_open_qpos
        self._home_qpos = home.to(self.device)
        actors = {**self.objects, TABLE: self.scene_builder.table}
        self.eval_context = EvalContext(
            self.scene, actors, entries, fingers, self.device, robot_links=self.agent.robot.get_links()
        )
        self.task_evaluator = TaskEvaluator(spec, self.eval_context)
        self.task_evaluator.track_events = self.track_events

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict) -> None:
        with torch.device(self.device):
            self.scene_builder.initialize(env_idx)
            count = len(env_idx)
            self.agent.reset(self._home_qpos.repeat(count, 1))
            self.agent.robot.set_pose(Pose.create(self._robot_base_pose()))
            if self.variation is not None:
                self.variation.initialize(self, env_idx)
            self.task_evaluator.reset(env_idx)

    # ------------------------------------------------------------------------------------------------ variations
    def _setup_variations(self, variations: Any, kwargs: dict) -> None:
        """Check the variation settings; they need one environment whose scene is rebuilt at every reset."""
        from robolab_ms.variations import Variations

        self.variations = Variations.create(variations)
        self.variation = None  # the current episode's EpisodeVariation (None without variations)
        self._sensor_effects_asked = self.sensor_effects
        if not self.variations:
            return
        if kwargs.get("num_envs", 1) != 1:
            raise RoboLabError(
                f"variations need one environment per process (num_envs=1), got num_envs={kwargs['num_envs']}"
            )
        if kwargs.setdefault("reconfiguration_freq", 1) != 1:
            raise RoboLabError("variations rebuild the scene at every reset: leave reconfiguration_freq at 1")

    def _draw_variation(self) -> None:
        """Draw this episode's variation parameters from its seed (a pure function of seed and settings)."""
        if not self.variations:
            self.variation, self.sensor_effects = None, self._sensor_effects_asked
            return
        from robolab_ms.variations import Context

        context = Context(self.task_spec, self.catalog, self.camera_names, len(self.robot.arm_joints))
        self.variation = self.variations.draw(int(self._episode_seed[0]), context)
        self.sensor_effects = self.variation.sensor_effects(self._sensor_effects_asked)

    def set_variations(self, variations: Any) -> None:
        """Use these variation settings (as the `variations` argument) from the next reset on."""
        from robolab_ms.variations import Variations

        if self.num_envs != 1 or self.reconfiguration_freq != 1:
            raise RoboLabError("set_variations needs one environment that rebuilds its scene at every reset")
        self.variations = Variations.create(variations)

    @property
    def variation_params(self) -> dict[str, float | int | str]:
        """The current episode's drawn variation parameters, flat (empty without variations)."""
        return {} if self.variation is None else dict(self.variation.fields)

    def gripper_closed_fraction(self) -> torch.Tensor:
        """How far the gripper is closed, 0 open to 1 closed: (num_envs,)."""
        return self.robot.closed_fraction(self.agent.robot.get_qpos()[:, self._gripper_joint_index])

    def arm_qpos(self) -> torch.Tensor:
        """Arm joint positions (rad), gripper excluded: (num_envs, arm joints)."""
        return self.agent.robot.get_qpos()[:, self._arm_joint_index]

    def arm_qvel(self) -> torch.Tensor:
        """Arm joint velocities (rad/s), gripper excluded: (num_envs, arm joints)."""
        return self.agent.robot.get_qvel()[:, self._arm_joint_index]

    def gripper_base_position(self) -> torch.Tensor:
        """Position of the gripper's base link (the robot binding's `gripper_base_link`), the point the
        end-effector metrics follow: (num_envs, 3), m."""
        link = self.agent.robot.links_map[self.robot.gripper_base_link]
        if self.gpu_sim_enabled:
            return link.pose.p
        # on the CPU simulator, the same float32 numbers read straight from SAPIEN (a hundred times faster)
        return torch.from_numpy(np.stack([body.entity_pose.p for body in link._objs]))

    def set_arm_qpos(self, arm_qpos: torch.Tensor | list[float]) -> None:
        """Teleport the arm to these joint positions (rad), for every environment; the gripper stays as it is."""
        qpos = self.agent.robot.get_qpos().clone()
        qpos[:, self._arm_joint_index] = torch.as_tensor(arm_qpos, dtype=qpos.dtype, device=self.device)
        self.agent.robot.set_qpos(qpos)

    def tcp_pose(self) -> Pose:
        """End-effector pose (between the fingertips)."""
        return self.agent.tcp_pose

    # ------------------------------------------------------------------------------------------------ episodes
    def reset(self, seed: int | list[int] | None = None, options: dict | None = None) -> tuple[Any, dict]:
        """ManiSkill's reset; on the CPU simulator the scene is rebuilt first, so nothing carries over from earlier
        episodes (see the module docstring)."""
        observation, info = super().reset(seed=seed, options=options)
        self._episode_actions = []
        self._episode_options = {key: value for key, value in (options or {}).items() if key != "reconfigure"}
        replayable = self._exact_episodes and not (options or {}).get("reset_to_env_states")
        self._episode_seed_used = int(self._episode_seed[0]) if replayable else None
        return observation, info

    def step(self, action: Any) -> tuple[Any, Any, Any, Any, dict]:
        if self._episode_seed_used is not None:
            self._episode_actions.append(_action_copy(action))
        return super().step(action)

    def get_state_dict(self) -> dict[str, Any]:
        """ManiSkill's state (poses, velocities, joint states, controller) plus `episode`: the seed and the step of
        the episode this state belongs to (-1 when the episode cannot be replayed), each (num_envs, 1) int64, shaped
        like every other entry (num_envs, D) so that ManiSkill's trajectory tools handle it as they handle those."""
        state = super().get_state_dict()
        seed = -1 if self._episode_seed_used is None else self._episode_seed_used
        state[EPISODE_STATE_KEY] = {
            "seed": torch.full((self.num_envs, 1), seed, dtype=torch.int64),
            "step": self._elapsed_steps.detach().to("cpu", torch.int64).reshape(self.num_envs, 1).clone(),
        }
        return state

    def set_state_dict(self, state: dict, env_idx: torch.Tensor | None = None) -> None:
        """Restore a state. A state of the current episode is restored exactly (the scene is rebuilt and the
        episode's actions replayed up to its step), so the same actions from there give bit-identical results;
        other states are set as ManiSkill sets them. Entries without the leading num_envs dimension (one step of a
        trajectory file's `env_states`) count as one environment's, as ManiSkill reads them."""
        state = _batched_state(state)
        episode = state.pop(EPISODE_STATE_KEY, None)
        if episode is not None and env_idx is None and self._restore_by_replay(state, episode):
            return
        super().set_state_dict(state, env_idx)
        if episode is not None:
            self._elapsed_steps[:] = torch.as_tensor(episode["step"], device=self.device).reshape(-1)
        self._episode_seed_used = None  # what follows is no longer a replayable episode

    def _restore_by_replay(self, state: dict, episode: dict) -> bool:
        """Rebuild the scene and replay this episode's actions up to the state's step; False when the state is not
        one of this episode's (its physics state after the replay differs)."""
        seed = int(torch.as_tensor(episode["seed"]).reshape(-1)[0])
        step = int(torch.as_tensor(episode["step"]).reshape(-1)[0])
        if (
            self._episode_seed_used is None
            or seed != self._episode_seed_used
            or not 0 <= step <= len(self._episode_actions)
        ):
            return False
        if step == int(self._elapsed_steps[0]) and _same_state(super().get_state_dict(), state):
            return True  # already in exactly that state
        actions = self._episode_actions[:step]
        self._replaying = True
        try:
            self.reset(seed=seed, options=self._episode_options)
            for action in actions:
                self.step(action)
        finally:
            self._replaying = False
        return _same_state(super().get_state_dict(), state)

    def get_obs(self, info: dict | None = None, unflattened: bool = False) -> Any:
        if self._replaying:
            return {}  # a replay to restore a state renders nothing
        return super().get_obs(info, unflattened=unflattened)

    def _flatten_raw_obs(self, obs: Any) -> Any:
        return obs if self._replaying else super()._flatten_raw_obs(obs)

    def render(self) -> Any:
        """ManiSkill's render(); a clear error when the environment has no renderer (`render_backend="none"`)."""
        if self.render_mode is not None and not scene_renders(self.scene):
            raise RoboLabError(
                f"render(): this environment was made with render_backend='none', so it has no "
                f"renderer for render_mode={self.render_mode!r}; make it with render_backend='cpu' "
                "(or 'gpu') to render, or with render_mode=None"
            )
        return super().render()

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
        evaluator = self.task_evaluator
        closed = self.gripper_closed_fraction() if evaluator.track_events else None  # only events read it
        return evaluator.evaluate(self.elapsed_steps, closed)

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


def _check_renderer_use(kwargs: dict) -> None:
    """Without a renderer (`render_backend="none"`) observations can only be states."""
    if kwargs.get("render_backend", "gpu") not in ("none", None):
        return
    obs_mode = kwargs.get("obs_mode") or "state"
    if obs_mode not in STATE_OBS_MODES:
        raise RoboLabError(
            f"obs_mode={obs_mode!r} needs camera images, but render_backend='none' renders nothing: "
            f"use obs_mode='state' or 'state_dict', or render_backend='cpu' (or 'gpu')"
        )


def _action_copy(action: Any) -> Any:
    """A copy of an action as given to step(), detached from the caller's buffers."""
    if isinstance(action, torch.Tensor):
        return action.detach().clone()
    if isinstance(action, np.ndarray):
        return action.copy()
    if isinstance(action, dict):
        return {key: _action_copy(value) for key, value in action.items()}
    return action


def _batched_state(state: dict) -> dict:
    """A (nested) state dict with a leading num_envs dimension on every entry: one-dimensional entries become (1, D)."""
    batched = {}
    for key, value in state.items():
        if isinstance(value, dict):
            batched[key] = _batched_state(value)
        else:
            batched[key] = value[None] if len(value.shape) == 1 else value
    return batched


def _same_state(a: Any, b: Any) -> bool:
    """Whether two (nested) state dicts hold bit-identical tensors under the same keys."""
    if isinstance(a, dict) or isinstance(b, dict):
        if not (isinstance(a, dict) and isinstance(b, dict)) or a.keys() != b.keys():
            return False
        return all(_same_state(a[key], b[key]) for key in a)
    a, b = torch.as_tensor(a).cpu(), torch.as_tensor(b).cpu()
    return a.shape == b.shape and torch.equal(a, b.to(a.dtype))
