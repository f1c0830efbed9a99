"""What an episode leaves behind besides its result line: event tallies (always), trajectory metrics (unless
`RecordOptions.metrics` is off), a ManiSkill trajectory file (`--record`, `--record-images`) and an mp4 (`--video`).

The runner drives one `EpisodeRecorder` per environment with four calls: `on_reset` after `env.reset`, `on_step`
after each `env.step`, `finish` when the episode is over (its return value goes into the `EpisodeResult`), and
`close` when the run ends. Everything is read from environment 0 of the batch.

Recording layout (one pair of files per episode, so parallel workers never share a file):

    OUT/recordings/<Task>/<variant>-<robot>-<policy>-seed<N>.h5 / .json   ManiSkill's trajectory format
    OUT/videos/<Task>/<variant>-<robot>-<policy>-seed<N>.mp4

The .json holds `env_info` (`env_id`, `env_kwargs`, `max_episode_steps`: enough for `gym.make`), `source_type`,
`source_desc`, one entry in `episodes` (`episode_id` 0, `episode_seed`, `reset_kwargs`, `control_mode`,
`elapsed_steps` T, `success`) and a `robolab` block (task, instruction variant and text, robot, policy, seed,
control_hz, cameras, arm joint names, score, progress, events, error, layout_version). The .h5 holds group
`traj_0` with, for T control steps:

| dataset | shape | what |
|---|---|---|
| `actions` | (T, 8) float32 | what the policy sent: 7 arm joint targets (rad) + gripper (0 open, 1 closed) |
| `terminated`, `truncated`, `success` | (T,) bool | after each step |
| `env_states/...` | (T + 1, D) | `env.get_state_dict()` at reset and after each step (replay / set_state_dict) |
| `obs/agent/qpos` | (T + 1, dof) float32 | every robot joint, gripper joints included |
| `obs/extra/tcp_pose` | (T + 1, 7) float32 | end-effector pose, position + quaternion (w, x, y, z) |
| `obs/extra/gripper_position` | (T + 1, 1) float32 | gripper closed fraction, 0 open .. 1 closed |
| `obs/sensor_data/<camera>/rgb` | (T + 1, H, W, 3) uint8 | policy camera images (`--record-images` only; gzip) |
| `robolab/joint_position` | (T + 1, 7) float32 | arm joint positions (rad), DROID's proprio with `gripper_position` |
| `robolab/joint_velocity` | (T + 1, 7) float32 | arm joint velocities (rad/s), as the simulator reports them |
| `robolab/gripper_base_position` | (T + 1, 3) float32 | position of the gripper's base link (m), the point of the end-effector metrics |
| `robolab/score`, `robolab/progress` | (T,) float32 | task score and subtask progress after each step |

Row t of the (T + 1) arrays is what the policy observed before action t; row T is the final state. The env states
are float32 but for `env_states/episode/seed` and `.../step`, int64 (T + 1, 1). Files are written under `*.partial`
names and renamed when complete.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.eval.metrics import event_tallies, trajectory_metrics
from robolab_ms.eval.results import to_json_value

RECORDINGS_DIR = "recordings"
VIDEOS_DIR = "videos"
LAYOUT_VERSION = 1
TRAJECTORY_KEY = "traj_0"


@dataclass(frozen=True)
class RecordOptions:
    """What to keep of each episode besides metrics and events."""

    trajectory: bool = False  # ManiSkill trajectory file: actions, env states, proprio, task signals
    images: bool = False  # also the policy cameras' images in the trajectory file (implies trajectory)
    video: bool = False  # an mp4 per episode
    metrics: bool = True  # trajectory metrics; off (validation's random episodes), nothing is read per step

    @property
    def writes_file(self) -> bool:
        return self.trajectory or self.images

    @property
    def follows_steps(self) -> bool:
        """Whether the recorder reads anything at each step."""
        return self.metrics or self.writes_file or self.video


def episode_stem(variant: str, robot: str, policy: str, seed: int) -> str:
    """The file name (no extension) of an episode's recording and video inside its task's folder.

    Characters other than letters, digits, `_` and `-` become `_` (ManiSkill's tools split file names at dots)."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", f"{variant}-{robot}-{policy}-seed{seed}")


def _numpy(value: Any) -> np.ndarray:
    if hasattr(value, "detach"):
        value = value.detach().cpu().numpy()
    return np.asarray(value)


def camera_views(base: Any, observation: Any = None) -> dict[str, np.ndarray]:
    """RGB images (H, W, 3) uint8 of the policy cameras in environment 0: taken from the observation when it
    carries them, otherwise rendered (colour only)."""
    sensor_data = observation.get("sensor_data") if isinstance(observation, dict) else None
    if sensor_data and all("rgb" in data for data in sensor_data.values()):
        return {name: _numpy(data["rgb"])[0] for name, data in sensor_data.items()}
    from mani_skill.sensors.camera import Camera

    base.scene.update_render(update_sensors=True, update_human_render_cameras=False)
    views = {}
    for name, sensor in base.scene.sensors.items():
        if isinstance(sensor, Camera):
            sensor.capture()
            views[name] = _numpy(sensor.get_obs(rgb=True, depth=False, position=False, segmentation=False)["rgb"])[0]
    return views


def _flat_state(state: dict) -> dict[str, np.ndarray]:
    """A nested state dict of (1, D) tensors as {'a/b': (D,) array}."""
    flat = {}
    for key, value in state.items():
        if isinstance(value, dict):
            flat.update({f"{key}/{inner}": array for inner, array in _flat_state(value).items()})
        else:
            flat[key] = _numpy(value)[0]
    return flat


class EpisodeRecorder:
    """Collects one episode at a time from `env` and writes what `options` asks for under `out_dir`."""

    def __init__(self, env: Any, out_dir: Path, options: RecordOptions, policy: str) -> None:
        from robolab_ms.tasks.spec import CONTROL_HZ

        self.env, self.base = env, env.unwrapped
        self.out_dir, self.options, self.policy = Path(out_dir), options, policy
        self.rate_hz = CONTROL_HZ
        low, high = self.base.single_action_space.low, self.base.single_action_space.high
        self.arm_dims = len(self.base.robot.arm_joints)
        self.arm_low, self.arm_high = low[: self.arm_dims], high[: self.arm_dims]
        self.video = None
        if options.video:
            from robolab_ms.eval.video import EpisodeVideo

            self.video = EpisodeVideo(fps=CONTROL_HZ)
        self._h5 = None
        self._started = False

    # ------------------------------------------------------------------------------------------------ episode
    def on_reset(self, seed: int, observation: Any, info: dict | None = None, max_steps: int | None = None) -> None:
        """Start an episode (call right after `env.reset(seed=seed)`)."""
        self._abandon_file()
        base = self.base
        self.seed, self.max_steps = int(seed), int(max_steps or 0)
        self.stem = episode_stem(base.instruction_variant, base.robot.uid, self.policy, seed)
        self.ee, self.arm, self.qpos, self.gripper = [], [], [], []
        self.gripper_base, self.arm_velocity = [], []
        self.actions, self.success, self.score, self.progress, self.terminated, self.truncated = [], [], [], [], [], []
        self.states: list[dict[str, np.ndarray]] = []
        self._started = self.options.follows_steps
        if not self._started:
            return
        self._read_robot()
        if self.options.writes_file:
            self._open_file()
            self.states.append(_flat_state(base.get_state_dict()))
        views = camera_views(base, observation) if (self.options.images or self.video) else {}
        if self.options.images:
            self._append_images(views)
        if self.video is not None:
            self.video.begin(self.video_path())
            self._add_video_frame(views, 0, info or {})

    def on_step(
        self, action: Any, observation: Any, info: dict, terminated: Any = False, truncated: Any = False
    ) -> None:
        """Record one control step (call right after `env.step(action)`)."""
        if not self._started:
            return
        base = self.base
        self.actions.append(np.asarray(_numpy(action), dtype=np.float32).reshape(-1))
        self.success.append(bool(_numpy(info.get("success", [False])).reshape(-1)[0]))
        self.score.append(float(_numpy(info.get("score", [0.0])).reshape(-1)[0]))
        self.progress.append(float(_numpy(info.get("progress", [0.0])).reshape(-1)[0]))
        self.terminated.append(bool(_numpy(terminated).reshape(-1)[0]))
        self.truncated.append(bool(_numpy(truncated).reshape(-1)[0]))
        self._read_robot()
        if self.options.writes_file:
            self.states.append(_flat_state(base.get_state_dict()))
        views = camera_views(base, observation) if (self.options.images or self.video) else {}
        if self.options.images:
            self._append_images(views)
        if self.video is not None:
            self._add_video_frame(views, len(self.actions), info)

    def finish(self, info: dict | None = None, error: str | None = None) -> dict[str, Any]:
        """End the episode: the `EpisodeResult` fields `metrics`, `event_counts`, `event_objects`, `recording`
        and `video` (paths relative to the results folder)."""
        info = info or {}
        events = list(info["events"][0]) if "events" in info else []
        counts, objects = event_tallies(events)
        extras: dict[str, Any] = {"event_counts": counts, "event_objects": objects}
        if not self._started:
            return extras
        self._started = False
        if self.options.metrics:
            targets = np.clip(
                np.asarray(self.actions, dtype=np.float64).reshape(-1, self.arm_dims + 1)[:, : self.arm_dims],
                self.arm_low,
                self.arm_high,
            )
            metrics = trajectory_metrics(
                np.asarray(self.gripper_base),
                np.asarray(self.arm),
                targets,
                1.0 / self.rate_hz,
                joint_velocities=np.asarray(self.arm_velocity),
            )
            extras["metrics"] = {key: None if math.isnan(value) else round(value, 6) for key, value in metrics.items()}
        if self.options.writes_file:
            self._write_file(info, events, error)
            extras["recording"] = self.recording_path().relative_to(self.out_dir).as_posix()
        if self.video is not None:
            self.video.end()
            extras["video"] = self.video_path().relative_to(self.out_dir).as_posix()
        return extras

    def close(self) -> None:
        """Finish pending videos (waits for the encoder) and drop an unfinished episode's partial file."""
        self._abandon_file()
        if self.video is not None:
            self.video.close()

    # ------------------------------------------------------------------------------------------------ paths
    def recording_path(self) -> Path:
        return self.out_dir / RECORDINGS_DIR / self.base.task_spec.name / f"{self.stem}.h5"

    def video_path(self) -> Path:
        return self.out_dir / VIDEOS_DIR / self.base.task_spec.name / f"{self.stem}.mp4"

    # ------------------------------------------------------------------------------------------------ internals
    def _read_robot(self) -> None:
        """What the metrics need every step, and what a trajectory file keeps when one is written."""
        base = self.base
        self.arm.append(_numpy(base.arm_qpos())[0].astype(np.float32))
        self.arm_velocity.append(_numpy(base.arm_qvel())[0].astype(np.float32))
        self.gripper_base.append(_numpy(base.gripper_base_position())[0].astype(np.float32))
        if self.options.writes_file:  # read only for the file: together these cost more than the metrics' reads
            self.ee.append(_numpy(base.tcp_pose().raw_pose)[0].astype(np.float32))
            self.qpos.append(_numpy(base.agent.robot.get_qpos())[0].astype(np.float32))
            self.gripper.append(float(_numpy(base.gripper_closed_fraction()).reshape(-1)[0]))

    def _add_video_frame(self, views: dict[str, np.ndarray], step: int, info: dict) -> None:
        from robolab_ms.eval.video import Caption

        events = list(info["events"][0]) if "events" in info else []
        caption = Caption(
            self.base.instruction,
            step,
            self.max_steps,
            self.score[-1] if self.score else 0.0,
            bool(self.success and self.success[-1]),
            tuple(events),
        )
        self.video.add(views, _numpy(self.base.render_rgb_array())[0], caption)

    def _open_file(self) -> None:
        import h5py

        path = self.recording_path()
        path.parent.mkdir(parents=True, exist_ok=True)
        self._partial = path.with_name(path.name + ".partial")
        self._h5 = h5py.File(self._partial, "w")
        self._group = self._h5.create_group(TRAJECTORY_KEY, track_order=True)

    def _append_images(self, views: dict[str, np.ndarray]) -> None:
        for name, image in views.items():
            key = f"obs/sensor_data/{name}/rgb"
            if key not in self._group:
                self._group.create_dataset(
                    key,
                    shape=(0, *image.shape),
                    maxshape=(None, *image.shape),
                    chunks=(1, *image.shape),
                    dtype=np.uint8,
                    compression="gzip",
                    compression_opts=5,
                )
            dataset = self._group[key]
            dataset.resize(dataset.shape[0] + 1, axis=0)
            dataset[-1] = image

    def _abandon_file(self) -> None:
        if self._h5 is not None:
            self._h5.close()
            self._h5 = None
            Path(self._partial).unlink(missing_ok=True)

    def _write_file(self, info: dict, events: list, error: str | None) -> None:
        group, steps = self._group, len(self.actions)
        action_dims = self.base.single_action_space.shape[0]
        actions = np.asarray(self.actions, dtype=np.float32).reshape(steps, action_dims)
        group.create_dataset("actions", data=actions)
        group.create_dataset("terminated", data=np.asarray(self.terminated, dtype=bool))
        group.create_dataset("truncated", data=np.asarray(self.truncated, dtype=bool))
        group.create_dataset("success", data=np.asarray(self.success, dtype=bool))
        for key in self.states[0]:
            group.create_dataset(f"env_states/{key}", data=np.stack([state[key] for state in self.states]))
        group.create_dataset("obs/agent/qpos", data=np.asarray(self.qpos, dtype=np.float32))
        group.create_dataset("obs/extra/tcp_pose", data=np.asarray(self.ee, dtype=np.float32))
        group.create_dataset("obs/extra/gripper_position", data=np.asarray(self.gripper, dtype=np.float32)[:, None])
        group.create_dataset("robolab/joint_position", data=np.asarray(self.arm, dtype=np.float32))
        group.create_dataset("robolab/joint_velocity", data=np.asarray(self.arm_velocity, dtype=np.float32))
        group.create_dataset("robolab/gripper_base_position", data=np.asarray(self.gripper_base, dtype=np.float32))
        group.create_dataset("robolab/score", data=np.asarray(self.score, dtype=np.float32))
        group.create_dataset("robolab/progress", data=np.asarray(self.progress, dtype=np.float32))
        self._h5.close()
        self._h5 = None
        path = self.recording_path()
        os.replace(self._partial, path)
        json_path = path.with_suffix(".json")
        partial_json = json_path.with_name(json_path.name + ".partial")
        partial_json.write_text(
            json.dumps(to_json_value(self._metadata(info, events, error)), indent=2), encoding="utf-8"
        )
        os.replace(partial_json, json_path)

    def _metadata(self, info: dict, events: list, error: str | None) -> dict[str, Any]:
        base, spec = self.base, self.base.task_spec
        kwargs = dict(base.spec.kwargs) if base.spec is not None else {}
        kwargs.pop("task", None)  # the env id names the task; the registered value may be a path of this machine
        success = bool(self.success[-1]) if self.success else False
        return {
            "env_info": {"env_id": spec.env_id, "env_kwargs": kwargs, "max_episode_steps": spec.max_episode_steps},
            "source_type": "robolab eval",
            "source_desc": f"robolab_ms evaluation of policy {self.policy}",
            "episodes": [
                {
                    "episode_id": 0,
                    "episode_seed": self.seed,
                    "reset_kwargs": {"seed": self.seed, "options": {}},
                    "control_mode": base.control_mode,
                    "elapsed_steps": len(self.actions),
                    "success": success,
                }
            ],
            "robolab": {
                "layout_version": LAYOUT_VERSION,
                "task": spec.name,
                "instruction_variant": base.instruction_variant,
                "instruction": base.instruction,
                "robot": base.robot.uid,
                "policy": self.policy,
                "seed": self.seed,
                "control_hz": self.rate_hz,
                "max_steps": self.max_steps,
                "cameras": list(base.camera_names),
                "arm_joints": list(base.robot.arm_joints),
                "success": success,
                "score": self.score[-1] if self.score else 0.0,
                "progress": self.progress[-1] if self.progress else 0.0,
                "events": events,
                "error": error,
            },
        }


# ---------------------------------------------------------------------------------------------------- replay
@dataclass
class ReplayReport:
    """How a replayed episode compares with its recording."""

    file: Path
    steps: int
    max_state_difference: float  # largest absolute difference of any env state value, over every step
    first_different_step: int | None  # the first step (0 = after reset) whose state differs beyond the tolerance
    recorded_success: bool
    replayed_success: bool
    recorded_score: float
    replayed_score: float
    tolerance: float = 0.0

    @property
    def matches(self) -> bool:
        return (
            self.first_different_step is None
            and self.recorded_success == self.replayed_success
            and abs(self.recorded_score - self.replayed_score) <= max(self.tolerance, 1e-6)
        )

    def line(self) -> str:
        verdict = "same" if self.matches else f"DIFFERS from step {self.first_different_step}"
        if self.first_different_step == 0:
            verdict += " (the initial state: the task, its scene or the catalog changed since the recording)"
        return (
            f"{self.file.name}: {self.steps} steps, {verdict} (largest state difference "
            f"{self.max_state_difference:.3g}); success {self.recorded_success} -> {self.replayed_success}, "
            f"score {self.recorded_score:.2f} -> {self.replayed_score:.2f}"
        )


def find_recordings(path: Path) -> list[Path]:
    """The recordings (.h5 with a .json beside it) of a results folder, or the one file given, in task and seed
    order. Files written by ManiSkill's replay tool (dotted names) are left out."""
    from robolab_ms.errors import RoboLabError

    path = Path(path)
    if path.is_file():
        if path.suffix != ".h5" or not path.with_suffix(".json").exists():
            raise RoboLabError(
                f"{path}: not a recording; give an .h5 written by `robolab eval --record` (its .json "
                "must be next to it) or a results folder"
            )
        return [path]
    if not path.is_dir():
        raise RoboLabError(f"{path}: no such file or folder")
    folder = path / RECORDINGS_DIR if (path / RECORDINGS_DIR).is_dir() else path
    files = [f for f in folder.rglob("*.h5") if "." not in f.stem and f.with_suffix(".json").exists()]
    if not files:
        raise RoboLabError(f"{path}: no recordings found; record episodes with `robolab eval --record --out {path}`")

    def order(file: Path) -> tuple:
        seed = re.search(r"seed(\d+)$", file.stem)
        return (file.parent.name, file.stem.rsplit("seed", 1)[0], int(seed.group(1)) if seed else -1)

    return sorted(files, key=order)


def _h5_leaves(group: Any, prefix: str = "") -> dict[str, np.ndarray]:
    import h5py

    leaves = {}
    for key, item in group.items():
        if isinstance(item, h5py.Group):
            leaves.update(_h5_leaves(item, f"{prefix}{key}/"))
        else:
            leaves[prefix + key] = item[()]
    return leaves


def replay_recording(file: Path, tolerance: float = 0.0) -> ReplayReport:
    """Replay one recording in a new environment built from its .json (state observations: nothing is rendered)
    and compare the env state after reset and after every step with the recorded one."""
    import gymnasium as gym
    import h5py

    import robolab_ms.envs  # noqa: F401  (registers the environments)
    from robolab_ms.errors import RoboLabError

    file = Path(file)
    meta = json.loads(file.with_suffix(".json").read_text(encoding="utf-8"))
    try:
        env_id, kwargs = meta["env_info"]["env_id"], dict(meta["env_info"]["env_kwargs"])
        episode = meta["episodes"][0]
    except (KeyError, IndexError, TypeError) as error:
        raise RoboLabError(
            f"{file.with_suffix('.json')}: field {error} missing; not a ManiSkill trajectory json"
        ) from None
    robolab = meta.get("robolab", {})
    with h5py.File(file, "r") as h5:
        group = h5[f"traj_{episode['episode_id']}"]
        actions = group["actions"][()]
        states = _h5_leaves(group["env_states"])
        recorded_score = float(group["robolab/score"][-1]) if "robolab/score" in group and len(actions) else 0.0
    kwargs["obs_mode"] = "state_dict"
    env = gym.make(env_id, **kwargs)
    try:
        base = env.unwrapped
        _, info = env.reset(**episode["reset_kwargs"])
        worst, first = 0.0, None

        def compare(step: int) -> None:
            nonlocal worst, first
            now = _flat_state(base.get_state_dict())
            difference = max(float(np.max(np.abs(now[key] - states[f"{key}"][step]), initial=0.0)) for key in states)
            worst = max(worst, difference)
            if difference > tolerance and first is None:
                first = step

        compare(0)
        for step, action in enumerate(actions, start=1):
            _, _, _, _, info = env.step(action)
            compare(step)
        replayed_success = bool(_numpy(info["success"]).reshape(-1)[0]) if len(actions) else False
        replayed_score = float(_numpy(info["score"]).reshape(-1)[0]) if len(actions) else 0.0
    finally:
        env.close()
    return ReplayReport(
        file,
        len(actions),
        worst,
        first,
        bool(robolab.get("success", episode.get("success", False))),
        replayed_success,
        float(robolab.get("score", recorded_score)),
        replayed_score,
        tolerance,
    )
