"""How often the paired comparison's 95 % intervals contain the truth, and how often the exact McNemar test calls a
task significant, on synthetic paired outcomes with a known difference (the numbers in docs/analysis.md).

Per repetition: T tasks, each with p_A ~ U(0.45, 0.95) and p_B = p_A - U(0, 0.4), so the mean difference over the
population of tasks is 0.20; N matched pairs per task with outcomes drawn independently. `compare_policies` gives
the overall bootstrap interval over tasks (checked against 0.20 and against the drawn tasks' own mean difference)
and a Newcombe interval per task (checked against that task's difference). Then, for McNemar, 2,000 tasks at fixed
rates: the share with p < 0.05.

    .venv/bin/python benchmarks/paired_coverage.py [--repetitions 300] [--resamples 2000]
"""

from __future__ import annotations

import argparse

import numpy as np

from robolab_ms.analysis.paired import compare_policies, paired_task_table
from robolab_ms.analysis.synthetic import paired_episode_frame

POPULATION_DIFFERENCE = 0.2
SETTINGS = ((5, 20), (10, 20), (20, 20), (30, 20), (30, 10), (60, 10))  # (tasks, pairs per task)


def interval_coverage(tasks: int, pairs: int, repetitions: int, resamples: int) -> tuple[float, float, float]:
    """Shares of repetitions whose overall interval holds the population and the sample mean difference, and
    share of per-task intervals holding their task's difference."""
    rng = np.random.default_rng(11)
    population = sample = per_task = 0
    for repetition in range(repetitions):
        rate_a = rng.uniform(0.45, 0.95, tasks)
        gap = rng.uniform(0.0, 0.4, tasks)
        result = compare_policies(
            paired_episode_frame(rng, rate_a, rate_a - gap, pairs), "a", "b", resamples=resamples, seed=repetition
        )
        low, high = result.overall["ci_low_%"], result.overall["ci_high_%"]
        population += low <= 100 * POPULATION_DIFFERENCE <= high
        sample += low <= 100 * gap.mean() <= high
        rows = result.per_task  # sorted by task name: the order drawn
        per_task += int(((rows["ci_low_%"] <= 100 * gap + 1e-9) & (100 * gap <= rows["ci_high_%"] + 1e-9)).sum())
    return population / repetitions, sample / repetitions, per_task / (repetitions * tasks)


def mcnemar_rejections(pairs: int, rate_a: float, rate_b: float, tasks: int = 2000) -> float:
    """Share of `tasks` tasks where the exact McNemar test gives p < 0.05."""
    rng = np.random.default_rng(3)
    episodes = paired_episode_frame(rng, np.full(tasks, rate_a), np.full(tasks, rate_b), pairs)
    wide = episodes.pivot_table(index=["task", "seed"], columns="policy", values="success")
    table = paired_task_table(wide.rename(columns={"a": "success_a", "b": "success_b"}).reset_index())
    return float((table["p_mcnemar"] < 0.05).mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=300)
    parser.add_argument("--resamples", type=int, default=2000)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    settings, mcnemar_pairs, mcnemar_tasks = SETTINGS, (10, 20, 30, 50), 2000
    if args.quick:
        args.repetitions, args.resamples = 2, 100
        settings, mcnemar_pairs, mcnemar_tasks = SETTINGS[:1], (10,), 50
    print("| tasks | pairs per task | overall interval holds 0.20 | holds these tasks' mean | per-task intervals |")
    print("|--:|--:|--:|--:|--:|")
    coverages = []
    for tasks, pairs in settings:
        population, sample, per_task = interval_coverage(tasks, pairs, args.repetitions, args.resamples)
        coverages.append((population, per_task))
        print(f"| {tasks} | {pairs} | {population:.3f} | {sample:.3f} | {per_task:.3f} |", flush=True)
    print("\n| pairs per task | no difference (0.6 vs 0.6) | 0.7 vs 0.5 | 0.9 vs 0.3 |")
    print("|--:|--:|--:|--:|")
    for pairs in mcnemar_pairs:
        shares = [mcnemar_rejections(pairs, a, b, mcnemar_tasks) for a, b in ((0.6, 0.6), (0.7, 0.5), (0.9, 0.3))]
        print(f"| {pairs} | " + " | ".join(f"{share:.3f}" for share in shares) + " |", flush=True)
    overall, per_task = (sum(c[i] for c in coverages) / len(coverages) for i in (0, 1))
    print(
        f"\nratio of 95 % intervals holding the truth, mean over the settings: overall {overall:.3f}, "
        f"per task {per_task:.3f} (nominal 0.95)"
    )


if __name__ == "__main__":
    main()
