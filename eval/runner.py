"""The evaluation runner: policies x tasks x episodes, resumable, with progress, into one results folder."""

from __future__ import annotations

import json
import platform
import subprocess
import time
import traceback
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.results import EpisodeResult, append_result, episode_key, read_results
from robolab_ms.policies import Policy

MANIFEST_FILE = "manifest.json"


@dataclass(frozen=True)
class EvalConfig:
    """What to run. An episode is fully defined by (task, instruction variant, robot, policy, seed)."""

    tasks: tuple[str, ...]
    episodes: int = 10
    instruction: str = "default"
    robot: str | None = None  # a robot uid (droid, panda, so100); None = the environments' default, droid
    first_seed: int = 0
    max_steps: int | None = None  # cut episodes short (for smoke tests); None = the task's episode length


def run_evaluation(policy: Policy, config: EvalConfig, out_dir: Path, show_progress: bool = True) -> list[EpisodeResult]:
    """Run every missing episode and append its result; returns all results of this policy in `out_dir`."""
    import gymnasium as gym

    import robolab_ms.envs  # noqa: F401  (registers the environments and the robots)
    from robolab_ms.agents import DEFAULT_ROBOT
    from robolab_ms.tasks.spec import load_task

    config = replace(config, robot=config.robot or DEFAULT_ROBOT)

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    specs = [load_task(task) for task in config.tasks]  # check every task before running any
    _write_manifest(out_dir, policy, config)
    done = {r.key() for r in read_results(out_dir)}
    todo = [
        (spec, seed)
        for spec in specs
        for seed in range(config.first_seed, config.first_seed + config.episodes)
        if episode_key(spec.name, config.instruction, config.robot, policy.name, seed) not in done
    ]
    skipped = len(specs) * config.episodes - len(todo)
    bar = tqdm(total=len(specs) * config.episodes, initial=skipped, desc=f"eval {policy.name}", unit="episode",
               disable=not show_progress, dynamic_ncols=True)  # fmt: skip
    env, env_task = None, None
    try:
        for spec, seed in todo:
            if env_task != spec.name:
                if env is not None:
                    env.close()
                bar.set_postfix_str(f"loading {spec.name}")
                env = gym.make(spec.env_id, obs_mode="rgb" if policy.needs_images else "state_dict",
                               instruction=config.instruction, robot_uids=config.robot, render_backend="cpu")  # fmt: skip
                env_task = spec.name
            result = _run_episode(env, policy, spec, config, seed, bar)
            append_result(out_dir, result)
            bar.update(1)
    finally:
        bar.close()
        if env is not None:
            env.close()
    return [r for r in read_results(out_dir) if r.policy == policy.name]


def _run_episode(env: Any, policy: Policy, spec: Any, config: EvalConfig, seed: int, bar: tqdm) -> EpisodeResult:
    base = env.unwrapped
    max_steps = min(spec.max_episode_steps, config.max_steps or spec.max_episode_steps)
    start = time.perf_counter()
    steps, success_step, info, error = 0, None, {}, None
    try:
        observation, info = env.reset(seed=seed)
        if policy.privileged:
            policy.bind(env)
        policy.reset(base.instruction, base.single_action_space, seed)
        while steps < max_steps:
            action = np.asarray(policy.act(observation), dtype=np.float32)
            observation, _, terminated, truncated, info = env.step(action)
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
        wall_seconds=round(time.perf_counter() - start, 3),
        error=error,
        events=list(info["events"][0]) if "events" in info else [],
    )


def _write_manifest(out_dir: Path, policy: Policy, config: EvalConfig) -> None:
    """Record versions, configuration and git revision of the latest invocation (one file per results folder)."""
    from importlib.metadata import version

    manifest = {
        "policy": policy.name,
        "config": {**config.__dict__, "tasks": list(config.tasks)},
        "versions": {pkg: version(pkg) for pkg in ("robolab-ms", "mani-skill", "sapien", "torch", "gymnasium")},
        "python": platform.python_version(),
        "platform": platform.platform(),
        "git_revision": _git_revision(),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    (out_dir / MANIFEST_FILE).write_text(json.dumps(manifest, indent=2), encoding="utf-8")


def _git_revision() -> str | None:
    try:
        output = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5,
                                cwd=Path(__file__).parent)  # fmt: skip
        return output.stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        return None
