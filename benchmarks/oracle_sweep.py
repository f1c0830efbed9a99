"""A timed oracle sweep: the privileged oracle on every task, one episode each (seed 0, state observations), on
worker processes, as `robolab eval --policy oracle --all --episodes 1 --workers N` runs it.

    .venv/bin/python benchmarks/oracle_sweep.py [--workers 2] [--seed 0] [--out results/oracle_sweep] [--task T ...]

First one BananaInBowl oracle episode runs in this process as the baseline (its wall time measures this machine's
speed right now); then the sweep. Printed: the sweep's wall time against the target (45 minutes for the 120 tasks
on a 2-core machine without a GPU, issue 15), the same time in baseline episodes (comparable across machines and
loads), how many tasks the oracle solved, and the slowest tasks. The episodes go to OUT/episodes.jsonl and a table
of every task (success, steps, wall seconds) to OUT/oracle_sweep.csv; a rerun with the same OUT resumes, and then
times only the episodes it ran.
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path

from robolab_ms.eval.parallel import PolicySpec, run_parallel
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import PolicyOptions, make_policy
from robolab_ms.tasks.spec import task_names

TARGET_MINUTES = 45.0  # issue 15: all 120 tasks on a 2-core machine without a GPU
BASELINE_TASK = "BananaInBowl"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default: 2)")
    parser.add_argument("--seed", type=int, default=0, help="the episode seed of every task (default: 0)")
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help="results folder (default: results/oracle_sweep; with --quick a temporary one)",
    )
    parser.add_argument("--task", nargs="+", help="only these tasks (default: every task)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.task, args.workers = [BASELINE_TASK], 1
    if args.out is None and args.quick:
        with tempfile.TemporaryDirectory(prefix="oracle-sweep-quick-") as folder:  # leaves nothing a later run resumes
            sweep(args, Path(folder))
    else:
        sweep(args, args.out or Path("results/oracle_sweep"))


def sweep(args: argparse.Namespace, out: Path) -> None:
    """The baseline episode, then the sweep into `out`; prints the results."""
    tasks = tuple(args.task or task_names())

    with tempfile.TemporaryDirectory() as scratch:
        start = time.perf_counter()
        baseline = run_evaluation(
            make_policy("oracle"),
            EvalConfig(tasks=(BASELINE_TASK,), episodes=1, first_seed=args.seed),
            Path(scratch),
            show_progress=False,
        )
        baseline_seconds = time.perf_counter() - start
    print(
        f"baseline: one {BASELINE_TASK} oracle episode, environment build included: {baseline_seconds:.1f} s "
        f"({'solved' if baseline[0].success else 'NOT solved'})",
        flush=True,
    )

    config = EvalConfig(tasks=tasks, episodes=1, first_seed=args.seed)
    start = time.perf_counter()
    results = run_parallel(
        make_policy("oracle"), PolicySpec("oracle", PolicyOptions()), config, out, workers=args.workers
    )
    seconds = time.perf_counter() - start
    results = [r for r in results if r.seed == args.seed and r.task in tasks]
    out.mkdir(parents=True, exist_ok=True)
    table = out / "oracle_sweep.csv"
    with table.open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["task", "success", "steps", "wall_seconds", "error"])
        for r in sorted(results, key=lambda r: r.task):
            writer.writerow([r.task, int(r.success), r.steps, round(r.wall_seconds, 2), r.error or ""])

    solved = sum(r.success for r in results)
    errors = sum(bool(r.error) for r in results)
    minutes = seconds / 60
    if len(tasks) == len(task_names()):
        verdict = f"target {TARGET_MINUTES:g} min for every task: {'met' if minutes <= TARGET_MINUTES else 'MISSED'}"
    else:
        verdict = f"{len(tasks)} of {len(task_names())} tasks; the {TARGET_MINUTES:g}-min target is for all of them"
    print(
        f"sweep: {len(results)} tasks, one oracle episode each, {args.workers} workers: {minutes:.1f} min ({verdict})"
    )
    print(f"ratio sweep / baseline episode: {seconds / baseline_seconds:.1f} (the sweep's time in baseline episodes)")
    print(
        f"solved: {solved} of {len(results)}; errors: {errors}; "
        f"summed episode time {sum(r.wall_seconds for r in results) / 60:.1f} min"
    )
    print(
        "slowest:",
        ", ".join(f"{r.task} {r.wall_seconds:.0f} s" for r in sorted(results, key=lambda r: -r.wall_seconds)[:8]),
    )
    print(f"table: {table}")


if __name__ == "__main__":
    main()
