"""What `robolab sensitivity` costs on a CPU: one analysis of 2,000 synthetic episodes (RoboLab's settings: MNPE
with the categorical light colour, 50 epochs, 5000 posterior samples), against baselines in the same process: 500
episodes, and plain NPE on the two continuous parameters.

    .venv/bin/python benchmarks/sensitivity_cost.py [--episodes 2000] [--baseline-episodes 500] [--threads 1]

Prints, per case, the fit (training and building the posterior: the `Fit` line of the command), the whole analysis
(loading the episodes excluded; sampling, ranking included), the CPU time of the whole analysis and the ratios to the
2,000-episode MNPE case. CPU seconds say more than wall seconds on a shared machine. Target: under 60 s.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from robolab_ms.analysis.runs import load_runs, task_table
from robolab_ms.analysis.sensitivity import analyse
from robolab_ms.analysis.synthetic import LIGHT_SPACE, light_dependent_success, write_synthetic_run

TASK = "BananaInBowl"


def timed_analysis(runs, params, epochs: int, samples: int, threads: int) -> tuple[float, float, float, str, str]:
    """(fit seconds, analysis seconds, analysis CPU seconds, method, top-ranked parameter) of one analysis."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = analyse(runs, params=params, epochs=epochs, samples=samples, seed=0, threads=threads)
    return (
        result.fit_seconds,
        time.perf_counter() - wall,
        time.process_time() - cpu,
        result.method,
        str(result.table["parameter"].iloc[0]),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=2000)
    parser.add_argument("--baseline-episodes", type=int, default=500)
    parser.add_argument("--epochs", type=int, default=50)
    parser.add_argument("--samples", type=int, default=5000)
    parser.add_argument("--threads", type=int, default=1, help="torch threads (the command's default: 1)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.episodes, args.baseline_episodes, args.epochs, args.samples = 60, 30, 2, 50

    info = task_table([TASK])
    with tempfile.TemporaryDirectory() as folder:
        runs = {}
        for count in (args.episodes, args.baseline_episodes):
            out = write_synthetic_run(
                Path(folder) / f"light_{count}", "p", [TASK], count, light_dependent_success, params=LIGHT_SPACE
            )
            runs[count] = load_runs([out], task_info=info)
        cases = [
            (f"MNPE, {args.episodes} episodes", runs[args.episodes], None),
            (f"MNPE, {args.baseline_episodes} episodes", runs[args.baseline_episodes], None),
            (
                f"NPE (continuous only), {args.episodes} episodes",
                runs[args.episodes],
                ["light_intensity", "cam_external_left_dx"],
            ),
        ]
        rows = []
        for name, episodes, params in cases:
            rows.append((name, *timed_analysis(episodes, params, args.epochs, args.samples, args.threads)))
            print(f"{name}: fit {rows[-1][1]:.1f} s", flush=True)
    reference = rows[0]
    print(
        f"\n{args.epochs} epochs, {args.samples} samples, {args.threads} torch thread(s); parameters "
        f"{', '.join(LIGHT_SPACE)} (success depends on light_intensity only)\n"
    )
    print("| case | method | fit s | analysis s | analysis CPU s | CPU / first | ranked first |")
    print("|---|---|---|---|---|---|---|")
    for name, fit, wall, cpu, method, top in rows:
        print(f"| {name} | {method} | {fit:.1f} | {wall:.1f} | {cpu:.1f} | {cpu / reference[3]:.2f} | {top} |")
    print(
        f"ratio analysis CPU time, {args.baseline_episodes} / {args.episodes} episodes (MNPE): "
        f"{rows[1][3] / reference[3]:.2f}"
    )


if __name__ == "__main__":
    main()
