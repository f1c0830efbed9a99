"""Synthetic results folders whose truth is known: for checking the analysis (interval coverage, paired tests,
sensitivity rankings) and for trying the analysis commands without running a policy.

A synthetic folder has the layout of a `robolab eval` folder (`episodes.jsonl`, one `EpisodeResult` per line, plus
a `manifest.json` that says it is synthetic). Each episode's success is drawn with a probability given per task, or
by a function of the task and the episode's drawn variation parameters, so an analysis can be checked against it.

    python -m robolab_ms.analysis.synthetic results/synth_a --policy good --success 0.7
    python -m robolab_ms.analysis.synthetic results/synth_b --policy weak --success 0.3 --vary-light
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd

from robolab_ms.eval.results import EPISODES_FILE, EpisodeResult
from robolab_ms.tasks.spec import CONTROL_HZ

# name -> (low, high) for a continuous parameter, or a list of names for a categorical one
ParamSpace = Mapping[str, "tuple[float, float] | Sequence[str]"]
SuccessModel = Callable[[str, dict], float]  # (task, drawn parameters) -> probability of success

LIGHT_SPACE: dict = {
    "light_intensity": (0.05, 3.0),
    "cam_external_left_dx": (-0.2, 0.2),
    "light_color": ["white", "warm", "cool", "red", "green", "blue"],
}


def light_dependent_success(task: str, params: dict) -> float:
    """Success that depends on the key light's intensity only: likely in good light, rare in the dark."""
    return float(np.clip(0.05 + 0.9 * (params["light_intensity"] - 0.05) / 2.95, 0.0, 1.0))


def draw_params(space: ParamSpace, rng: np.random.Generator) -> dict:
    """One episode's parameters: continuous ones uniform in their range, categorical ones uniform over names."""
    drawn: dict = {}
    for name, values in space.items():
        if isinstance(values, tuple):
            drawn[name] = float(rng.uniform(values[0], values[1]))
        else:
            drawn[name] = str(values[int(rng.integers(len(values)))])
    return drawn


def synthetic_episode(
    task: str,
    seed: int,
    success_probability: float,
    rng: np.random.Generator,
    policy: str,
    max_steps: int = 900,
    params: dict | None = None,
    variant: str = "default",
) -> EpisodeResult:
    """One made-up episode whose success is drawn with `success_probability`; other fields plausible."""
    success = bool(rng.random() < success_probability)
    success_step = int(rng.integers(max_steps // 10, max_steps // 2)) if success else None
    steps = success_step + 1 if success else max_steps
    progress = 1.0 if success else float(rng.choice([0.0, 0.0, 0.5]))
    score = 1.0 if success else round(progress * float(rng.uniform(0.5, 1.0)), 3)
    wrong = int(rng.poisson(0.3 if success else 0.8))
    events = [
        {"step": int(rng.integers(1, steps)), "type": "wrong_object_grasped", "object": "distractor"}
        for _ in range(wrong)
    ]
    path = float(rng.uniform(0.4, 1.5)) * (steps / max_steps + 0.5)
    metrics = {
        "ee_sparc": float(-rng.uniform(3, 12)),
        "joint_sparc_mean": float(-rng.uniform(3, 12)),
        "ee_isj": float(rng.uniform(10, 500)),
        "joint_isj": float(rng.uniform(10, 500)),
        "ee_path_length": path,
        "ee_speed_mean": path / (steps / CONTROL_HZ),
        "ee_speed_max": float(rng.uniform(0.2, 0.6)),
        "joint_rmse_mean": float(rng.uniform(0.01, 0.05)),
        "joint_tracking_max": float(rng.uniform(0.05, 0.2)),
    }
    return EpisodeResult(
        task=task,
        instruction_variant=variant,
        instruction=f"(synthetic) {task}",
        robot="droid",
        policy=policy,
        seed=seed,
        success=success,
        score=score,
        progress=progress,
        steps=steps,
        max_steps=max_steps,
        success_step=success_step,
        wall_seconds=0.0,
        events=sorted(events, key=lambda e: e["step"]),
        metrics=metrics,
        event_counts={"wrong_object_grasped": wrong} if wrong else {},
        event_objects={"wrong_object_grasped": ["distractor"]} if wrong else {},
        variations="synthetic" if params else None,
        variation=dict(params or {}),
    )


def write_synthetic_run(
    out_dir: str | Path,
    policy: str,
    tasks: Sequence[str],
    episodes_per_task: int,
    success: float | Mapping[str, float] | SuccessModel,
    seed: int = 0,
    params: ParamSpace | None = None,
    variants: Sequence[str] = ("default",),
    max_steps: int = 900,
) -> Path:
    """Write a results folder of made-up episodes: for every task, variant and seed 0..episodes_per_task-1, one
    episode whose success is drawn with probability `success` (one number, one per task, or a function of the task
    and the drawn `params`). The same `seed` gives the same folder; the draws for a (task, variant, episode seed)
    do not depend on `policy`, so two policies' folders share their parameters episode by episode."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    lines = []
    for task in tasks:
        for variant in variants:
            for episode_seed in range(episodes_per_task):
                key = [seed, _stable_hash(task), _stable_hash(variant), episode_seed]
                drawn = draw_params(params, np.random.default_rng(key)) if params else {}
                if callable(success):
                    probability = success(task, drawn)
                elif isinstance(success, Mapping):
                    probability = success[task]
                else:
                    probability = float(success)
                outcome_rng = np.random.default_rng([*key, _stable_hash(policy)])
                episode = synthetic_episode(
                    task, episode_seed, probability, outcome_rng, policy, max_steps, drawn, variant
                )
                lines.append(json.dumps(asdict(episode), sort_keys=True) + "\n")
    (out / EPISODES_FILE).write_text("".join(lines), encoding="utf-8")  # the results format, written at once
    manifest = {
        "synthetic": True,
        "policy": policy,
        "tasks": list(tasks),
        "episodes_per_task": episodes_per_task,
        "seed": seed,
        "params": {k: list(v) for k, v in (params or {}).items()},
    }
    (out / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return out


def paired_episode_frame(rng: np.random.Generator, rate_a: np.ndarray, rate_b: np.ndarray, pairs: int) -> pd.DataFrame:
    """Episode rows (as `load_runs` gives them, the columns a paired comparison reads) of policies `a` and `b` on
    len(rate_a) tasks T000, T001, ..., `pairs` matched seeds each, outcomes drawn independently with the per-task
    success rates `rate_a` and `rate_b`: for checking paired comparisons against a known difference."""
    tasks = np.repeat([f"T{i:03d}" for i in range(len(rate_a))], pairs)
    seeds = np.tile(np.arange(pairs), len(rate_a))
    a = rng.random(len(tasks)) < np.repeat(rate_a, pairs)
    b = rng.random(len(tasks)) < np.repeat(rate_b, pairs)
    return pd.DataFrame(
        {
            "task": np.concatenate([tasks, tasks]),
            "instruction_variant": "default",
            "robot": "droid",
            "seed": np.concatenate([seeds, seeds]),
            "policy": ["a"] * len(tasks) + ["b"] * len(tasks),
            "run": ["ra"] * len(tasks) + ["rb"] * len(tasks),
            "success": np.concatenate([a, b]),
        }
    )


def _stable_hash(text: str) -> int:
    """A hash of `text` that is the same in every process (Python's own hash is salted per process)."""
    value = 0
    for byte in text.encode("utf-8"):
        value = (value * 131 + byte) % (2**31 - 1)
    return value


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m robolab_ms.analysis.synthetic",
        description="Write a results folder of made-up episodes with a known success rate, to try or check the "
        "analysis commands (robolab analyze / sensitivity / leaderboard) without running a policy.",
    )
    parser.add_argument("out", help="results folder to write (its episodes.jsonl is replaced)")
    parser.add_argument("--policy", default="synthetic", help="policy name on every line (default: synthetic)")
    parser.add_argument(
        "--success", type=float, default=0.5, help="probability of success of every episode (default: 0.5)"
    )
    parser.add_argument("--tasks", nargs="+", metavar="TASK", help="task names (default: every known task)")
    parser.add_argument("--episodes", type=int, default=10, help="episodes per task and variant (default: 10)")
    parser.add_argument("--variants", nargs="+", default=["default"], help="instruction variants (default: default)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws (default: 0)")
    parser.add_argument(
        "--vary-light",
        action="store_true",
        help="draw light_intensity, light_color and cam_external_left_dx per episode and make "
        "success depend on light_intensity only (ignores --success)",
    )
    args = parser.parse_args(argv)
    if not 0.0 <= args.success <= 1.0 or math.isnan(args.success):
        parser.error(f"--success {args.success}: give a probability between 0 and 1")
    if args.episodes < 1:
        parser.error(f"--episodes {args.episodes}: give at least 1")
    if args.tasks:
        tasks = args.tasks
    else:
        from robolab_ms.analysis.runs import task_table

        tasks = list(task_table().index)
    if args.vary_light:
        out = write_synthetic_run(
            args.out, args.policy, tasks, args.episodes, light_dependent_success, args.seed, LIGHT_SPACE, args.variants
        )
    else:
        out = write_synthetic_run(
            args.out, args.policy, tasks, args.episodes, args.success, args.seed, variants=args.variants
        )
    print(f"wrote {len(tasks) * len(args.variants) * args.episodes} synthetic episodes to {out / EPISODES_FILE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
