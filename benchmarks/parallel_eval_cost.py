"""Episodes per second of `robolab eval` with --workers 1 (in this process), --workers 2 (two worker processes) and
--ray local --workers 2 (two Ray actors on a Ray instance started on this machine), all in one process.

    .venv/bin/python benchmarks/parallel_eval_cost.py [--task BananaInBowl] [--episodes 24] [--max-steps 60] [--rounds 2]

Each mode runs the same episodes (random policy, state observations) into its own fresh results folder; the modes
take turns, `--rounds` times, and the median of each counts. Printed per mode: episodes per second over the whole
run (worker start-up and Ray's start included) and in steady state (workers / mean episode time), and the speed-ups
against --workers 1.
Targets (issue 20): at least 1.7x with 2 workers on a 2-core machine, Ray within 10 % of --workers 2. The numbers
are only meaningful on an otherwise idle machine: other processes take cores from the workers, and Linux's
per-session fair share (autogroup) caps all processes of a run (Ray's included) at one session's share of a busy
machine. The script prints how many cores this session gets with two processes before and after: the ceiling of the
speed-up it can measure.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # Ray on this machine only (127.0.0.1)
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

from robolab_ms.eval.parallel import PolicySpec, run_parallel  # noqa: E402
from robolab_ms.eval.runner import EvalConfig, run_evaluation  # noqa: E402
from robolab_ms.policies import PolicyOptions, make_policy  # noqa: E402


def measure(label: str, workers: int, ray: bool, config: EvalConfig, root: Path) -> tuple[float, float]:
    """(episodes/s over the whole run, episodes/s in steady state) of one mode. Steady state: the workers each run
    episodes back to back, so together they finish `workers / mean episode time` episodes per second (start-up,
    environment builds between tasks and hand-over gaps left out)."""
    out = root / label.replace(" ", "_")
    policy = make_policy("random")
    start = time.perf_counter()
    if workers == 1 and not ray:
        results = run_evaluation(policy, config, out, show_progress=False)
    else:
        results = run_parallel(
            policy,
            PolicySpec("random", PolicyOptions()),
            config,
            out,
            workers=workers,
            ray="local" if ray else None,
            show_progress=False,
        )
    seconds = time.perf_counter() - start
    episodes = len(config.tasks) * config.episodes
    assert len(results) == episodes and not any(r.error for r in results), f"{label}: episodes missing or errored"
    whole = episodes / seconds
    steady = workers / statistics.mean(r.wall_seconds for r in results)
    print(
        f"{label:>18}: {whole:6.3f} episodes/s whole run ({seconds:6.1f} s), {steady:6.3f} episodes/s steady",
        flush=True,
    )
    return whole, steady


SPIN = "import time\nstart = time.perf_counter()\nx = 0\nfor i in range(6_000_000): x += i\nprint(time.perf_counter() - start)"


def available_parallelism(processes: int = 2) -> float:
    """How many cores this session gets right now: a pure-Python loop alone, then `processes` copies at once.

    Linux gives each session (autogroup) a fair share of a busy machine, so on a shared machine the workers of one
    run may get no more CPU than one process."""
    import subprocess
    import sys

    def run(count: int) -> float:
        started = [
            subprocess.Popen([sys.executable, "-c", SPIN], stdout=subprocess.PIPE, text=True) for _ in range(count)
        ]
        return max(float(process.communicate()[0]) for process in started)

    alone = run(1)
    return processes * alone / run(processes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="BananaInBowl")
    parser.add_argument("--episodes", type=int, default=24)
    parser.add_argument("--max-steps", type=int, default=60, help="control steps per episode")
    parser.add_argument("--rounds", type=int, default=2, help="times each mode runs (the median counts)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.episodes, args.max_steps, args.rounds = 2, 3, 1

    config = EvalConfig(tasks=(args.task,), episodes=args.episodes, max_steps=args.max_steps)
    print(
        f"{args.episodes} episodes of {args.task}, {args.max_steps} steps each, random policy; "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}; cores this session gets with 2 "
        f"processes: {available_parallelism():.2f}",
        flush=True,
    )
    modes = {"--workers 1": (1, False), "--workers 2": (2, False), "--ray local -w 2": (2, True)}
    rates: dict[str, list[tuple[float, float]]] = {label: [] for label in modes}
    with tempfile.TemporaryDirectory(prefix="parallel-eval-cost-") as folder:
        for round_index in range(args.rounds):
            for label, (workers, ray) in modes.items():
                rates[label].append(measure(label, workers, ray, config, Path(folder) / f"round{round_index}"))
    print(
        f"load average after: {os.getloadavg()[0]:.2f}; cores this session gets with 2 processes: "
        f"{available_parallelism():.2f} (the most --workers 2 can gain here)"
    )
    one, two, ray = ([statistics.median(rate[i] for rate in rates[label]) for i in (0, 1)] for label in modes)
    print(
        "medians: "
        + "; ".join(
            f"{label} {whole:.3f} / {steady:.3f} episodes/s (whole / steady)"
            for label, (whole, steady) in zip(modes, (one, two, ray))
        )
    )
    for index, kind in enumerate(("whole run", "steady")):
        print(
            f"speed-up ratio ({kind}): --workers 2 / --workers 1 = {two[index] / one[index]:.2f}x (target >= 1.7); "
            f"Ray / --workers 2 = {ray[index] / two[index]:.2f} (target >= 0.90)"
        )


if __name__ == "__main__":
    main()
