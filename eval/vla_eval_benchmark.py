"""RoboLab-120 as a vla-eval benchmark: `vla-eval run` drives our environments against any vla-eval model server.

vla-eval (the `vla-eval` package, the robolab-ms[vla-eval] extra) evaluates model servers over one websocket +
msgpack protocol. This module is the benchmark side, named in a vla-eval config by its import path:

    benchmarks:
      - benchmark: "robolab_ms.eval.vla_eval_benchmark:RoboLabBenchmark"
        mode: sync                     # or live (real time): then also hz: 15
        episodes_per_task: 10
        params: {tasks: [BananaInBowl], seed: 0}

Episodes are `robolab eval`'s: the same environments and settings (`env_kwargs`), tasks chosen the same way
(`tasks.selection.select_tasks`), seeds seed, seed + 1, ... (vla-eval's episode index added to `seed`), actions
checked and clipped as the runner does (`runner.checked_action`), and the same metrics (`EpisodeRecorder`), so a
replayed episode ends with the same success, score and step count as under `robolab eval`.

Each observation is exactly the request our openpi client sends a DROID policy (`policies.openpi.droid_request`):

    observation/exterior_image_1_left, observation/wrist_image_left   uint8 224x224x3, resized with padding
    observation/joint_position (7,) float32 rad, observation/gripper_position (1,) float32 (0 open, 1 closed)
    prompt                                                              the task instruction

(no images with `images: false`, for model servers that read only the robot's state). The model server answers
`{"actions": (8,)}`: 7 absolute arm joint targets (rad) and the gripper (> 0.5 closes). The task dict a model
server receives at episode start names the task, instruction variant, robot, variation settings and, added when
the episode starts, its `seed` and the action bounds `action_low` / `action_high`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from vla_eval.benchmarks.base import StepBenchmark, StepResult
from vla_eval.specs import IMAGE_RGB, LANGUAGE, STATE_JOINT, DimSpec
from vla_eval.types import Action, EpisodeResult, Observation, Task

from robolab_ms.errors import RoboLabError

ACTION_FORMAT = "droid_joint_position_gripper"  # absolute arm joint targets (rad), then the gripper (0 open, 1 closed)
LAVAPIPE_ICD_ENV = "ROBOLAB_MS_LAVAPIPE_ICD"  # render: cpu: the lavapipe Vulkan ICD file, if not in a usual place
RESULTS_POLICY_NAME = "vla-eval"  # the policy name our episode recorder files episodes under (nothing is written)


def _names(value: Any, param: str) -> list[str] | None:
    """A parameter given as one name or a list of names, as a list (None when not given)."""
    if value is None:
        return None
    values = [value] if isinstance(value, str) else value
    if not isinstance(values, (list, tuple)) or not all(isinstance(v, str) and v.strip() for v in values):
        raise RoboLabError(f"vla-eval params.{param}: expected a name or a list of names, got {value!r}")
    return [v.strip() for v in values]


def _whole_number(value: Any, param: str, least: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or (least is not None and value < least):
        floor = f" of at least {least}" if least is not None else ""
        raise RoboLabError(f"vla-eval params.{param}: expected a whole number{floor}, got {value!r}")
    return value


class RoboLabBenchmark(StepBenchmark):
    """RoboLab-120's tasks, one vla-eval task per task (and per suite condition).

    Args (the `params:` of a vla-eval config; names and meanings as `robolab eval`'s options):
        tasks: task names or task files, or `all` (default: every task, or those the filters keep).
        tag, difficulty, scene: keep tasks with any of these tags (attributes or axes), difficulties, scenes.
        instruction: instruction variant: default, vague or specific.
        robot: droid (default), panda or so100.
        vary: domain randomization settings (`--vary`), one text or a list.
        suite: a named suite, `NAME` or `NAME:COND/COND`: every task once per condition, named `<Task>/<condition>`.
        seed: the first episode's seed; episode i of a task has seed `seed + i`, as in `robolab eval --seed`.
        max_steps: cut episodes after this many control steps (default: each task's length).
        images: send the two camera images (False: the robot's state and the prompt only, nothing rendered).
    """

    render_backends: ClassVar[frozenset[str]] = frozenset({"gpu", "cpu"})
    _render_mode: ClassVar[str] = "gpu"
    _ALL_RECORD_FIELDS = frozenset({"success", "score", "progress", "terminated", "truncated"})

    @classmethod
    def configure_render(cls, mode: str) -> dict[str, str]:
        """`render: cpu` renders in software (lavapipe), exactly as `robolab eval` does; `render: gpu` (vla-eval's
        default) renders on the GPU when there is one (CUDA), else falls back to the CPU renderer."""
        from vla_eval.render import configure_sapien_render

        applied = configure_sapien_render(mode, LAVAPIPE_ICD_ENV)
        cls._render_mode = mode
        return applied

    def __init__(
        self,
        tasks: str | list[str] | None = None,
        tag: str | list[str] | None = None,
        difficulty: str | list[str] | None = None,
        scene: str | list[str] | None = None,
        instruction: str = "default",
        robot: str | None = None,
        vary: str | list[str] | None = None,
        suite: str | None = None,
        seed: int = 0,
        max_steps: int | None = None,
        images: bool = True,
    ) -> None:
        super().__init__()
        import robolab_ms.envs  # noqa: F401  (registers the environments and the robots)
        from robolab_ms.agents import DEFAULT_ROBOT, robot_binding
        from robolab_ms.tasks.selection import ALL_TASKS, select_tasks
        from robolab_ms.tasks.spec import INSTRUCTION_VARIANTS, is_task_file, load_task
        from robolab_ms.variations import Variations, suite_conditions

        if instruction not in INSTRUCTION_VARIANTS:
            raise RoboLabError(
                f"vla-eval params.instruction: '{instruction}' is not an instruction variant; use "
                f"one of {', '.join(INSTRUCTION_VARIANTS)}"
            )
        if not isinstance(images, bool):
            raise RoboLabError(f"vla-eval params.images: expected true or false, got {images!r}")
        if suite is not None and not isinstance(suite, str):
            raise RoboLabError(f"vla-eval params.suite: expected NAME or NAME:COND/COND, got {suite!r}")
        self.seed = _whole_number(seed, "seed")
        self.max_steps = None if max_steps is None else _whole_number(max_steps, "max_steps", least=1)
        self.instruction, self.images = instruction, images
        self.robot = robot_binding(robot or DEFAULT_ROBOT)
        names = select_tasks(
            _names(tasks, "tasks") or [ALL_TASKS],
            _names(tag, "tag"),
            _names(difficulty, "difficulty"),
            _names(scene, "scene"),
        )
        vary_names = _names(vary, "vary")
        vary_text = Variations.create(",".join(vary_names)).text if vary_names else ""
        conditions = suite_conditions(suite)[1] if suite else {"": ""}
        self._tasks: list[Task] = []
        seen: set[str] = set()
        for name in names:
            spec = load_task(name)
            if spec.name in seen:
                raise RoboLabError(f"vla-eval params.tasks: the task {spec.name} is given twice; give it once")
            seen.add(spec.name)
            if is_task_file(name):
                robolab_ms.envs.register_task_file(spec.file, replace=True)
            length = min(spec.max_episode_steps, self.max_steps or spec.max_episode_steps)
            for condition, settings in conditions.items():
                text = ",".join(t for t in (vary_text, settings) if t)
                self._tasks.append(
                    {
                        "name": f"{spec.name}/{condition}" if condition else spec.name,
                        "task": spec.name,
                        "env_id": spec.env_id,
                        "instruction_variant": instruction,
                        "instruction": spec.instructions[instruction],
                        "robot": self.robot.uid,
                        "variations": Variations.create(text).text if text else "",
                        "condition": condition,
                        "max_steps": length,
                    }
                )
        self._env: Any = None
        self._env_key: tuple[str, str] | None = None
        self._episode: dict[str, Any] = {}

    # ------------------------------------------------------------------------------------------------ declarations
    def get_tasks(self) -> list[Task]:
        return [dict(task) for task in self._tasks]

    def get_metadata(self) -> dict[str, Any]:
        from robolab_ms.tasks.spec import CONTROL_HZ

        return {"max_steps": max(task["max_steps"] for task in self._tasks), "control_hz": CONTROL_HZ}

    def get_action_spec(self) -> dict[str, DimSpec]:
        arm = len(self.robot.arm_joints)
        return {
            "actions": DimSpec(
                "actions",
                arm + 1,
                ACTION_FORMAT,
                accepts=frozenset({ACTION_FORMAT, "raw"}),
                description=f"{arm} absolute arm joint targets (rad), then the gripper "
                "(0 open, 1 closed; above 0.5 closes)",
            )
        }

    def get_observation_spec(self) -> dict[str, DimSpec]:
        from robolab_ms.policies.openpi import OPENPI_KEY_PREFIX

        spec: dict[str, DimSpec] = {}
        if self.images:
            for key in ("exterior_image_1_left", "wrist_image_left"):
                spec[OPENPI_KEY_PREFIX + key] = DimSpec(key, 0, IMAGE_RGB.format, description="224x224, padded")
        spec[OPENPI_KEY_PREFIX + "joint_position"] = DimSpec(
            "joint_position", len(self.robot.arm_joints), STATE_JOINT.format
        )
        spec[OPENPI_KEY_PREFIX + "gripper_position"] = DimSpec("gripper_position", 1, "continuous_01", (0.0, 1.0))
        spec["prompt"] = DimSpec("prompt", 0, LANGUAGE.format)
        return spec

    def get_metric_keys(self) -> dict[str, str]:
        """Success rate, mean score and progress, arm targets clipped per episode, every trajectory metric (mean
        over the episodes that have it) and every event type (mean count per episode)."""
        from robolab_ms.eval.metrics import trajectory_metrics
        from robolab_ms.tasks.events import EVENT_TYPES

        still = trajectory_metrics(np.zeros((2, 3)), np.zeros((2, 1)), np.zeros((1, 1)), 1.0)  # just for the names
        keys = {"success": "mean", "score": "mean", "progress": "mean", "clipped_steps": "mean"}
        return {**keys, **{name: "mean" for name in still}, **{kind: "mean" for kind in EVENT_TYPES}}

    def get_hold_action(self, last_action: Action | None) -> Action:
        """Hold the last target; before the first one, the arm where it is (at home before any episode) with the
        gripper as it is."""
        if last_action is not None:
            return last_action
        if self._env is None:
            return {"actions": np.array([*self.robot.home_arm_qpos, 0.0], dtype=np.float32)}
        base = self._env.unwrapped
        closed = float(base.gripper_closed_fraction().reshape(-1)[0]) > 0.5
        return {"actions": np.append(base.arm_qpos()[0].cpu().numpy(), np.float32(closed)).astype(np.float32)}

    # ------------------------------------------------------------------------------------------------ episodes
    def reset(self, task: Task) -> Any:
        """Start the task's episode `task["episode_idx"]` with seed `seed + episode_idx`; adds `seed`,
        `action_low` and `action_high` to `task` (vla-eval sends the task to the model server after this)."""
        self._make_env(task)
        base = self._env.unwrapped
        seed = self.seed + int(task.get("episode_idx", 0))
        observation, info = self._env.reset(seed=seed)
        self._metrics.on_reset(seed, observation, info, task["max_steps"])
        space = base.single_action_space
        task.update(seed=seed, action_low=[float(v) for v in space.low], action_high=[float(v) for v in space.high])
        self._episode = {
            "task": task,
            "seed": seed,
            "steps": 0,
            "success_step": None,
            "clipped_steps": 0,
            "info": info,
            "variation": base.variation_params,
            "result": None,
        }
        self._recorder.record_video(self._frame(observation))
        return observation

    def step(self, action: Action) -> StepResult:
        from robolab_ms.eval.runner import checked_action

        episode, space = self._episode, self._env.unwrapped.single_action_space
        clipped, arm_clipped = checked_action(self._action_values(action), space, "the model server")
        observation, _, terminated, truncated, info = self._env.step(clipped)
        self._metrics.on_step(clipped, observation, info, terminated, truncated)
        episode["steps"] += 1
        episode["clipped_steps"] += int(arm_clipped)
        episode["info"] = info
        success = bool(info["success"][0])
        if success:
            episode["success_step"] = episode["steps"]
        ended, cut = bool(terminated[0]), bool(truncated[0])
        self._recorder.record_step(
            success=success,
            score=float(info["score"][0]),
            progress=float(info["progress"][0]),
            terminated=ended,
            truncated=cut,
        )
        self._recorder.record_video(self._frame(observation))
        done = ended or cut or episode["steps"] >= episode["task"]["max_steps"]
        return StepResult(obs=observation, reward=float(success), done=done, info=info)

    def make_obs(self, raw_obs: Any, task: Task) -> Observation:
        from robolab_ms.policies.openpi import droid_request

        return droid_request(self._droid.observation(raw_obs))

    def get_step_result(self, step_result: StepResult) -> EpisodeResult:
        """The episode's outcome as vla-eval metrics: success, score, progress, steps, clipped arm targets, event
        counts, trajectory metrics (None where one cannot be computed), and what defines the episode."""
        from robolab_ms.eval.results import to_json_value
        from robolab_ms.tasks.events import EVENT_TYPES

        episode = self._episode
        if episode.get("result") is None:
            info, task = episode["info"], episode["task"]
            extras = self._metrics.finish(info)
            counts = extras["event_counts"]
            episode["result"] = to_json_value(
                {
                    "success": bool(info["success"][0]),
                    "score": float(info["score"][0]),
                    "progress": float(info["progress"][0]),
                    "steps": episode["steps"],
                    "max_steps": task["max_steps"],
                    "success_step": episode["success_step"],
                    "clipped_steps": episode["clipped_steps"],
                    **{kind: counts.get(kind, 0) for kind in EVENT_TYPES},
                    **extras.get("metrics", {}),
                    "task": task["task"],
                    "instruction_variant": task["instruction_variant"],
                    "instruction": task["instruction"],
                    "robot": task["robot"],
                    "seed": episode["seed"],
                    "variations": task["variations"],
                    "condition": task["condition"],
                    "variation": episode["variation"],
                    "events": list(info["events"][0]),
                    "event_objects": extras["event_objects"],
                }
            )
        return dict(episode["result"])

    def cleanup(self) -> None:
        self._close_env()

    # ------------------------------------------------------------------------------------------------ internals
    def _make_env(self, task: Task) -> None:
        """The environment for this task and variation settings (kept while they stay the same)."""
        key = (task["env_id"], task["variations"])
        if self._env is not None and self._env_key == key:
            return
        self._close_env()
        import gymnasium as gym

        from robolab_ms.envs.droid_obs import DroidObservation
        from robolab_ms.eval.recording import EpisodeRecorder, RecordOptions
        from robolab_ms.eval.runner import EvalConfig, env_kwargs

        config = EvalConfig(
            tasks=(task["task"],),
            instruction=self.instruction,
            robot=self.robot.uid,
            variations=task["variations"] or None,
        )
        kwargs = {**env_kwargs(self.images, config), "render_backend": "cpu" if self._render_mode == "cpu" else "gpu"}
        self._env = gym.make(task["env_id"], **kwargs)
        self._env_key = key
        self._droid = DroidObservation(self._env, images=self.images)
        self._metrics = EpisodeRecorder(self._env, Path.cwd(), RecordOptions(), RESULTS_POLICY_NAME)

    def _close_env(self) -> None:
        if self._env is not None:
            self._metrics.close()
            self._env.close()
            self._env, self._env_key = None, None

    def _action_values(self, action: Action) -> np.ndarray:
        """The one action of a model server's reply: `actions` (or `action`) of shape (D,) or (1, D)."""
        values = action.get("actions", action.get("action")) if isinstance(action, dict) else None
        if values is None:
            keys = sorted(action) if isinstance(action, dict) else type(action).__name__
            raise RoboLabError(f"the model server's reply has no 'actions' (it holds {keys})")
        values = np.asarray(values, dtype=np.float32)
        if values.ndim == 2 and values.shape[0] > 1:
            raise RoboLabError(
                f"the model server sent {values.shape[0]} actions at once; RoboLab executes one per "
                "step: give the model server a chunk_size (PredictModelServer(chunk_size=N)) so that "
                "vla-eval hands out its chunks one action at a time"
            )
        return values.reshape(-1) if values.ndim == 2 else values

    def _frame(self, observation: Any) -> np.ndarray | None:
        """The exterior camera's image for vla-eval's episode video (None without images)."""
        if not self.images:
            return None
        return self._droid.observation(observation)["exterior_image_1_left"][0]
