"""Task validation: is a task stable at rest, not passed at reset, not passed by chance, and solvable by the oracle?

Per task over N seeds:
- stability: with the arm holding still, no object drifts more than 2 cm over 300 physics steps after reset;
- success at reset: the task must not count as solved right after reset;
- random policy: its success rate (expected near 0; above 10 % the task is too easy to pass by flailing);
- oracle: its success rate (at least 90 %) and time per episode.
Episodes of both policies go through the evaluation runner, into OUT/episodes.jsonl, so a rerun resumes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from robolab_ms.eval.runner import EvalConfig, run_evaluation

STABILITY_PHYSICS_STEPS = 300
MAX_DRIFT_M = 0.02
MAX_RANDOM_SUCCESS = 0.10
MIN_ORACLE_SUCCESS = 0.90
REPORT_CSV, REPORT_MD = "validation.csv", "validation.md"


@dataclass(frozen=True)
class TaskValidation:
    """One task's validation row."""

    task: str
    seeds: int
    max_drift_cm: float
    success_at_reset: int
    random_success: float
    oracle_success: float
    oracle_seconds: float
    oracle_errors: str
    passed: bool
    problems: str


def check_rest(task: str, seeds: range) -> tuple[float, int]:
    """Largest object drift (m) over 300 physics steps with the arm holding still, and how many seeds count as
    solved right after reset."""
    import gymnasium as gym

    import robolab_ms.envs  # noqa: F401  (registers the environments)
    from robolab_ms.tasks.spec import load_task

    env = gym.make(load_task(task).env_id, obs_mode="state_dict", render_backend="cpu")
    base = env.unwrapped
    worst, solved = 0.0, 0
    try:
        for seed in seeds:
            _, info = env.reset(seed=seed)
            solved += bool(info["success"][0])
            start = {name: actor.pose.p[0].clone() for name, actor in base.objects.items()}
            hold = np.concatenate([base.arm_qpos()[0].numpy(), [0.0]]).astype(np.float32)
            for _ in range(-(-STABILITY_PHYSICS_STEPS // (base.sim_freq // base.control_freq))):
                env.step(hold)
            for name, actor in base.objects.items():
                worst = max(worst, float((actor.pose.p[0] - start[name]).norm()))
    finally:
        env.close()
    return worst, solved


def validate_task(task: str, seeds: int, out_dir: Path, first_seed: int = 0, show_progress: bool = True) -> TaskValidation:
    """Run every check on one task; episodes go to `out_dir`."""
    from robolab_ms.policies import make_policy

    drift, solved_at_reset = check_rest(task, range(first_seed, first_seed + seeds))
    config = EvalConfig(tasks=(task,), episodes=seeds, first_seed=first_seed)
    random_results = run_evaluation(make_policy("random"), config, out_dir, show_progress)
    oracle_results = run_evaluation(make_policy("oracle"), config, out_dir, show_progress)
    oracle_results = [r for r in oracle_results if r.task == task]
    random_results = [r for r in random_results if r.task == task]
    random_rate = float(np.mean([r.success for r in random_results]))
    oracle_rate = float(np.mean([r.success for r in oracle_results]))
    errors = sorted({r.error for r in oracle_results if r.error})
    problems = []
    if drift > MAX_DRIFT_M:
        problems.append(f"an object drifts {drift * 100:.1f} cm at rest (max {MAX_DRIFT_M * 100:.0f})")
    if solved_at_reset:
        problems.append(f"solved at reset in {solved_at_reset} seed(s)")
    if random_rate > MAX_RANDOM_SUCCESS:
        problems.append(f"random policy succeeds {random_rate:.0%} (max {MAX_RANDOM_SUCCESS:.0%})")
    if oracle_rate < MIN_ORACLE_SUCCESS:
        problems.append(f"oracle succeeds only {oracle_rate:.0%} (min {MIN_ORACLE_SUCCESS:.0%})")
    return TaskValidation(
        task=task,
        seeds=seeds,
        max_drift_cm=round(drift * 100, 2),
        success_at_reset=solved_at_reset,
        random_success=round(random_rate, 3),
        oracle_success=round(oracle_rate, 3),
        oracle_seconds=round(float(np.mean([r.wall_seconds for r in oracle_results])), 2),
        oracle_errors="; ".join(errors),
        passed=not problems,
        problems="; ".join(problems),
    )


def write_report(rows: list[TaskValidation], out_dir: Path) -> Path:
    """Write OUT/validation.csv and OUT/validation.md; returns the Markdown file."""
    import pandas as pd

    from robolab_ms.analysis.tables import to_markdown

    table = pd.DataFrame([asdict(row) for row in rows])
    table.to_csv(out_dir / REPORT_CSV, index=False)
    markdown = out_dir / REPORT_MD
    markdown.write_text(to_markdown(table) + "\n")
    return markdown
