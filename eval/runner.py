"""The evaluation runner: policies x tasks x episodes, resumable, with progress, into one results folder."""

from __future__ import annotations

import json
import platform
import shlex
import subprocess
import sys
import time
import traceback
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from robolab_ms.errors import RoboLabError, make_folder
from robolab_ms.eval.recording import EpisodeRecorder, RecordOptions
from robolab_ms.eval.results import (
    EpisodeResult,
    append_result,
    episode_key,
    exclusive_writer,
    read_results,
    to_json_value,
)
from robolab_ms.policies import EpisodeInfo, Policy, PolicyReplyError, PolicyUnavailableError

MANIFEST_FILE = "manifest.json"
ADAPTIVE_MIN_EPISODES = 10  # adaptive sampling never judges a task on fewer episodes


@dataclass(frozen=True)
class EvalConfig:
    """What to run. An episode is fully defined by (task, instruction variant, robot, policy, seed)."""

    tasks: tuple[str, ...]
    episodes: int = 10
    instruction: str = "default"
    robot: str | None = None  # a robot uid (droid, panda, so100); None = the environments' default, droid
    first_seed: int = 0
    max_steps: int | None = None  # cut episodes short (for smoke tests); None = the task's episode length
    record: RecordOptions = field(default_factory=RecordOptions)  # trajectory file, images, video per episode
    episodes_adaptive: int | None = (
        None  # if set: per task, add episodes until the interval is narrow, at most this many
    )
    ci_width: float = 0.14  # adaptive sampling stops once the 95 % Beta interval of the success rate is this narrow
    retry_errors: bool = False  # run episodes again whose last result is errored (otherwise a rerun skips them)
    save_actions: bool = False  # keep each episode's executed actions (OUT/actions/..., for the replay policy)
    reconnect_seconds: float = 30.0  # after a lost policy server: retry connecting this long before giving up
    variations: str | None = None  # domain randomization settings (`--vary` text, robolab_ms.variations); None: none
    condition: str | None = None  # the suite condition these settings come from (`--suite`), recorded per episode

    @property
    def episodes_at_most(self) -> int:
        return self.episodes_adaptive or self.episodes


def env_kwargs(needs_images: bool, config: EvalConfig, reads_observations: bool = True) -> dict[str, Any]:
    """The keyword arguments of `gym.make` for every task of this evaluation, for a policy that reads camera
    images (`needs_images`), only the state, or no observation at all (not `reads_observations`)."""
    kwargs = {
        "obs_mode": "rgb" if needs_images else "state_dict" if reads_observations else "none",
        "instruction": config.instruction,
        "robot_uids": config.robot,
        "render_backend": "cpu",
    }
    if config.variations:
        kwargs["variations"] = config.variations
    return kwargs


def policy_env_kwargs(policy: Policy, config: EvalConfig) -> dict[str, Any]:
    """`env_kwargs` for what this policy reads."""
    return env_kwargs(policy.needs_images, config, policy.reads_observations)


def adaptive_sampling_done(successes: int, episodes: int, max_episodes: int, ci_width: float) -> bool:
    """Whether a task has enough episodes: `max_episodes` reached, or at least 10 and the 95 % Beta interval of
    the success rate at most `ci_width` wide."""
    from robolab_ms.analysis.tables import success_interval

    if episodes >= max_episodes:
        return True
    if episodes < ADAPTIVE_MIN_EPISODES:
        return False
    low, high = success_interval(successes, episodes)
    return high - low <= ci_width


def run_evaluation(
    policy: Policy, config: EvalConfig, out_dir: Path, show_progress: bool = True
) -> list[EpisodeResult]:
    """Run every missing episode and append its result; returns all results of this policy in `out_dir`.

    The policy is connected first: PolicyUnavailableError (no server at the address) stops before any episode."""
    make_folder(out_dir, "--out")
    with exclusive_writer(out_dir):  # one run per results folder at a time
        policy.connect()
        try:
            return _run_all(policy, config, out_dir, show_progress)
        finally:
            policy.close()


def _run_all(policy: Policy, config: EvalConfig, out_dir: Path, show_progress: bool) -> list[EpisodeResult]:
    import gymnasium as gym

    import robolab_ms.envs  # noqa: F401  (registers the environments and the robots)
    from robolab_ms.agents import DEFAULT_ROBOT
    from robolab_ms.tasks.spec import load_task

    config = replace(config, robot=config.robot or DEFAULT_ROBOT)

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    specs = [load_task(task) for task in config.tasks]  # check every task before running any
    _write_manifest(out_dir, policy, config)
    done = {r.key(): r for r in read_results(out_dir)}
    _check_same_variations(done.values(), policy, config, out_dir)
    _check_same_timing(done.values(), policy, out_dir)
    bar = tqdm(
        total=len(specs) * config.episodes_at_most,
        desc=f"eval {policy.name}",
        unit="episode",
        disable=not show_progress,
        dynamic_ncols=True,
    )
    env, env_task, recorder = None, None, None
    try:
        for spec in specs:
            successes, count = 0, 0
            for seed in range(config.first_seed, config.first_seed + config.episodes_at_most):
                if config.episodes_adaptive and adaptive_sampling_done(
                    successes, count, config.episodes_adaptive, config.ci_width
                ):
                    bar.total -= config.episodes_at_most - count
                    bar.refresh()
                    break
                result = done.get(episode_key(spec.name, config.instruction, config.robot, policy.name, seed))
                if result is None or (config.retry_errors and result.error is not None):
                    if policy.needs_reconnect:
                        _reconnect(policy, config.reconnect_seconds, out_dir)
                    if env_task != spec.name:
                        if recorder is not None:
                            recorder.close()
                        if env is not None:
                            env.close()
                        bar.set_postfix_str(f"loading {spec.name}")
                        env = gym.make(spec.env_id, **policy_env_kwargs(policy, config))
                        env_task = spec.name
                        recorder = EpisodeRecorder(env, out_dir, config.record, policy.name)
                    result = _run_episode(env, policy, spec, config, seed, bar, recorder, out_dir)
                    append_result(out_dir, result)
                successes, count = successes + int(result.success), count + 1
                bar.update(1)
            _write_tables(out_dir, policy)
    finally:
        bar.close()
        if recorder is not None:
            recorder.close()
        if env is not None:
            env.close()
    return [r for r in read_results(out_dir) if r.policy == policy.name]


def _write_tables(out_dir: Path, policy: Policy) -> None:
    """Summary and per-task CSVs of this policy's episodes so far (after each task, so a stopped run has them)."""
    from robolab_ms.analysis.tables import write_summary

    write_summary([r for r in read_results(out_dir) if r.policy == policy.name], out_dir)


def _droid_view(env: Any) -> Any:
    """A DroidObservation over `env` whose `observation()` turns the env's observations into DROID's keys."""
    from robolab_ms.envs.droid_obs import DroidObservation

    return DroidObservation(env)


def checked_action(action: np.ndarray, space: Any, source: str) -> tuple[np.ndarray, bool]:
    """An action as the environment executes it: `space`'s shape and finite (else PolicyReplyError naming
    `source`), clipped to its bounds; and whether an arm joint target was clipped (the gripper's range is clipped
    without counting)."""
    if action.shape != space.shape or not np.isfinite(action).all():
        raise PolicyReplyError(
            f"{source} returned the action {action.tolist()}; expected {space.shape[0]} finite numbers"
        )
    clipped = np.clip(action, space.low, space.high)
    return clipped, bool(np.any(np.abs(clipped[:-1] - action[:-1]) > 1e-6))


class _PolicyStats:
    """Per episode: the policy's queries and their times, env step times, clipped steps, executed actions."""

    def __init__(self) -> None:
        self.query_ms: list[float] = []
        self.env_ms: list[float] = []
        self.clipped_steps = 0
        self.actions: list[np.ndarray] = []

    def act(self, policy: Policy, observation: Any, space: Any) -> np.ndarray:
        """The policy's next action, checked, with arm joint targets clipped to the robot's limits."""
        start = time.perf_counter()
        action = np.asarray(policy.act(observation), dtype=np.float32).reshape(-1)
        elapsed = (time.perf_counter() - start) * 1000.0
        queries = policy.pop_query_times()
        self.query_ms.extend([elapsed] if queries is None else queries)
        clipped, arm_clipped = checked_action(action, space, f"policy '{policy.name}'")
        self.clipped_steps += int(arm_clipped)
        self.actions.append(clipped)
        return clipped

    def fields(self, policy: Policy, steps: int, wall_seconds: float) -> dict[str, Any]:
        """The policy-facing fields of a result line."""
        query = np.asarray(self.query_ms)
        return {
            "endpoint": policy.endpoint,
            "policy_metadata": to_json_value(policy.metadata()),
            "queries": len(query),
            "inference_ms_mean": round(float(query.mean()), 3) if len(query) else None,
            "inference_ms_p95": round(float(np.percentile(query, 95)), 3) if len(query) else None,
            "env_step_ms": round(float(np.mean(self.env_ms)), 3) if self.env_ms else None,
            "steps_per_second": round(steps / wall_seconds, 3) if wall_seconds > 0 else None,
            "clipped_steps": self.clipped_steps,
            **self.realtime_fields(policy),
        }

    def realtime_fields(self, policy: Policy) -> dict[str, Any]:
        """The result line's real-time fields (`--realtime`, docs/policies.md)."""
        return {
            "realtime": policy.realtime,
            "held_steps": policy.held_steps if policy.realtime else None,
            "inference_ms_max": round(max(self.query_ms), 3) if self.query_ms else None,
        }


def _reconnect(policy: Policy, seconds: float, out_dir: Path) -> None:
    """Connect again after a fault, waiting 0.5, 1, 2, 4 ... s between tries, for at most `seconds` in all."""
    deadline = time.monotonic() + seconds
    wait, tries, last = 0.5, 0, None
    while True:
        tries += 1
        try:
            policy.connect()
            return
        except PolicyUnavailableError as exc:
            last = exc
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            break
        time.sleep(min(wait, remaining))
        wait = min(wait * 2, 8.0)
    raise PolicyUnavailableError(
        f"lost the policy at {policy.endpoint} and could not reconnect in {seconds:g} s ({tries} tries; last: "
        f"{last}). Finished episodes are kept in {out_dir}; start the server again and rerun the same command to "
        "resume (add --retry-errors to run the errored episodes again)."
    )


def _run_episode(
    env: Any,
    policy: Policy,
    spec: Any,
    config: EvalConfig,
    seed: int,
    bar: tqdm,
    recorder: EpisodeRecorder | None = None,
    out_dir: Path | None = None,
) -> EpisodeResult:
    base = env.unwrapped
    max_steps = min(spec.max_episode_steps, config.max_steps or spec.max_episode_steps)
    start = time.perf_counter()
    steps, success_step, info, error, variation = 0, None, {}, None, {}
    droid = _droid_view(env) if policy.needs_images else None
    space = base.single_action_space
    stats = _PolicyStats()
    try:
        observation, info = env.reset(seed=seed)
        variation = base.variation_params
        if recorder is not None:
            recorder.on_reset(seed, observation, info, max_steps)
        if policy.privileged:
            policy.bind(env)
        policy.start_episode(
            EpisodeInfo(
                task=spec.name,
                instruction_variant=config.instruction,
                instruction=base.instruction,
                robot=config.robot,
                seed=seed,
            )
        )
        policy.reset(base.instruction, space, seed)
        while steps < max_steps:
            action = stats.act(policy, droid.observation(observation) if droid is not None else observation, space)
            step_start = time.perf_counter()
            observation, _, terminated, truncated, info = env.step(action)
            stats.env_ms.append((time.perf_counter() - step_start) * 1000.0)
            if recorder is not None:
                recorder.on_step(action, observation, info, terminated, truncated)
            steps += 1
            if bool(info["success"][0]):
                success_step = steps
            if steps % 25 == 0:
                bar.set_postfix_str(f"{spec.name} seed {seed} step {steps}/{max_steps}", refresh=False)
            if bool(terminated[0]) or bool(truncated[0]):
                break
    except RoboLabError as exc:  # a policy that says why it gives up (e.g. the oracle): no traceback needed
        error = f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # one broken episode must not end the run; it is recorded with its error
        error = f"{type(exc).__name__}: {exc}"
        traceback.print_exc()
    extras = recorder.finish(info, error) if recorder is not None else {}
    wall_seconds = time.perf_counter() - start
    if config.save_actions:
        from robolab_ms.policies.replay import actions_file, save_actions

        save_actions(
            actions_file(out_dir, policy.name, spec.name, config.instruction, config.robot, seed), stats.actions
        )
    return EpisodeResult(
        task=spec.name,
        instruction_variant=config.instruction,
        instruction=spec.instructions[config.instruction],
        robot=config.robot,
        policy=policy.name,
        seed=seed,
        success=bool(info.get("success", [False])[0]) if error is None else False,
        score=float(info["score"][0]) if "score" in info else 0.0,
        progress=float(info["progress"][0]) if "progress" in info else 0.0,
        steps=steps,
        max_steps=max_steps,
        success_step=success_step,
        wall_seconds=round(wall_seconds, 3),
        error=error,
        events=list(info["events"][0]) if "events" in info else [],
        **stats.fields(policy, steps, wall_seconds),
        **extras,
        variations=config.variations or None,
        condition=config.condition,
        variation=variation,
    )


def _check_same_variations(done: Any, policy: Policy, config: EvalConfig, out_dir: Path) -> None:
    """A results folder holds one policy's episodes under one variation setting: resuming into a folder whose
    episodes ran under other settings would mix them (and skip episodes as if done)."""
    settings = {r.variations or None for r in done if r.policy == policy.name}
    others = settings - {config.variations or None}
    if others:
        found = ", ".join(sorted(f"'{o}'" if o else "none" for o in others))
        given = f"'{config.variations}'" if config.variations else "none"
        raise RoboLabError(
            f"{out_dir} holds episodes of policy '{policy.name}' run with variations {found}, not "
            f"{given}; give another --out for these settings"
        )


def _check_same_timing(done: Any, policy: Policy, out_dir: Path) -> None:
    """A results folder holds one policy's episodes either all synchronous or all in real time (`--realtime`)."""
    if any(r.realtime != policy.realtime for r in done if r.policy == policy.name):
        found, given = ("synchronously", "--realtime") if policy.realtime else ("with --realtime", "synchronously")
        raise RoboLabError(
            f"{out_dir} holds episodes of policy '{policy.name}' run {found}; to run it {given}, give "
            "another --out (or --policy-name)"
        )


def _write_manifest(out_dir: Path, policy: Policy, config: EvalConfig) -> None:
    """Record versions, configuration and git revision of the latest invocation (one file per results folder)."""
    from importlib.metadata import version

    manifest = {
        "policy": policy.name,
        "config": asdict(config),
        "command": ["robolab", *sys.argv[1:]] if Path(sys.argv[0]).name == "robolab" else list(sys.argv),
        "rerun": rerun_command(policy, config, out_dir),
        "env_kwargs": policy_env_kwargs(policy, config),
        **_variation_manifest(config),
        "versions": {pkg: version(pkg) for pkg in ("robolab-ms", "mani-skill", "sapien", "torch", "gymnasium")},
        "python": platform.python_version(),
        "platform": platform.platform(),
        "git_revision": _git_revision(),
        "git_uncommitted_changes": _git_dirty(),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    (out_dir / MANIFEST_FILE).write_text(json.dumps(manifest, indent=2), encoding="utf-8")


def rerun_command(policy: Policy, config: EvalConfig, out_dir: Path) -> str:
    """A `robolab eval` command line that runs exactly these episodes again (into `out_dir`)."""
    words = ["robolab", "eval", "--policy", policy.made_as or policy.name]
    if policy.made_as:
        words += ["--policy-name", policy.name]
    words += [
        "--task",
        *config.tasks,
        "--instruction",
        config.instruction,
        "--seed",
        str(config.first_seed),
        "--out",
        str(out_dir),
    ]
    if config.episodes_adaptive:
        words += ["--episodes-adaptive", str(config.episodes_adaptive), "--ci-width", f"{config.ci_width:g}"]
    else:
        words += ["--episodes", str(config.episodes)]
    if config.robot:
        words += ["--robot", config.robot]
    if config.max_steps:
        words += ["--max-steps", str(config.max_steps)]
    if config.record.images:
        words.append("--record-images")
    elif config.record.trajectory:
        words.append("--record")
    if config.record.video:
        words.append("--video")
    if config.save_actions:
        words.append("--save-actions")
    if config.variations:
        words += ["--vary", config.variations]
    words += policy.command_line_options()
    return shlex.join(words)


def _git_dirty() -> bool | None:
    """Whether tracked files differ from the recorded revision (None outside a git checkout)."""
    try:
        output = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
            cwd=Path(__file__).parent,
        )
        return bool(output.stdout.strip()) if output.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        return None


def _git_revision() -> str | None:
    try:
        output = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5, cwd=Path(__file__).parent
        )
        return output.stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        return None


def _variation_manifest(config: EvalConfig) -> dict[str, Any]:
    """The manifest's `variations` entry: the settings and every parameter's range (empty without variations)."""
    if not config.variations:
        return {}
    from robolab_ms.variations import Variations

    return {
        "variations": {
            "settings": config.variations,
            "condition": config.condition,
            "ranges": Variations.create(config.variations).ranges(),
        }
    }
