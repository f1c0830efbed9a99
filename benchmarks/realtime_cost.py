"""What a slow policy loses when the simulation does not wait for it: synchronous vs `robolab eval --realtime`.

The oracle's episodes are recorded in process (`--save-actions`) and served back on this machine by
`robolab serve --policy replay --delay-ms 200` (openpi protocol, chunks of 10 actions as pi0's; every answer leaves
200 ms after its request came in). The openpi client plays them with the default open-loop horizon of 8 and the
episodes cut at --max-steps: synchronously (the simulation waits for every reply, so the replay reproduces the
oracle's episodes) and with --realtime (the delay and the round trip pass in simulated time at 15 Hz: the arm goes
on with its chunk, then holds; late actions are skipped), once per --delay-ms. The replay serves the actions meant
for each step, an open-loop plan: what it loses is what the timing alone costs, not what a closed-loop policy would
do with late observations. Printed: a markdown table.

    .venv/bin/python benchmarks/realtime_cost.py [--tasks T ...] [--episodes 3] [--delay-ms 200 ...] [--max-steps 200]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from robolab_ms.eval.results import EpisodeResult
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import PolicyOptions, make_policy
from robolab_ms.policies.server import free_port, start_serve_process

TASKS = ("BananaInBowl", "PickUpGreenObject", "RubiksCubeLeftOfBowl")


def row(name: str, results: list[EpisodeResult]) -> str:
    successes = [r for r in results if r.success]
    to_success = f"{np.mean([r.success_step for r in successes]):.1f}" if successes else "-"
    held = [r.held_steps for r in results if r.held_steps is not None]
    held_text = f"{sum(held)} / {sum(r.steps for r in results)}" if held else "-"
    latency = f"{np.mean([r.inference_ms_mean for r in results]):.0f} / {max(r.inference_ms_max for r in results):.0f}"
    return (
        f"| {name} | {len(successes)}/{len(results)} | {np.mean([r.score for r in results]):.2f} | {to_success} | "
        f"{held_text} | {sum(r.queries for r in results)} | {latency} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), help=f"default: {' '.join(TASKS)}")
    parser.add_argument("--episodes", type=int, default=3, help="seeds 0 .. N-1 per task (default: 3)")
    parser.add_argument(
        "--delay-ms",
        type=float,
        nargs="+",
        default=[200.0],
        help="the served policy's delays, one real-time run each (default: 200)",
    )
    parser.add_argument("--max-steps", type=int, default=200, help="episodes cut here (default: 200 = 13.3 s)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.tasks, args.episodes, args.delay_ms, args.max_steps = args.tasks[:1], 1, [200.0], 20

    config = EvalConfig(tasks=tuple(args.tasks), episodes=args.episodes, max_steps=args.max_steps)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder)
        oracle = run_evaluation(
            make_policy("oracle"), replace(config, save_actions=True), out / "oracle", show_progress=False
        )
        runs: dict[str, list[EpisodeResult]] = {}
        modes = [(f"synchronous, {args.delay_ms[0]:g} ms", args.delay_ms[0], False)]
        modes += [(f"real time, {delay:g} ms", delay, True) for delay in args.delay_ms]
        for mode, delay, realtime in modes:
            port = free_port()
            server = start_serve_process(
                ["--policy", "replay", "--replay-from", str(out / "oracle"), "--delay-ms", f"{delay:g}"], port
            )
            try:
                options = PolicyOptions(port=port, realtime=realtime)
                runs[mode] = run_evaluation(
                    make_policy("openpi", options), config, out / f"{realtime}{delay:g}", show_progress=False
                )
            finally:
                server.terminate()
                server.wait(timeout=30)
            print(f"{mode} done after {time.perf_counter() - started:.0f} s", file=sys.stderr, flush=True)
    errors = [f"{r.task} seed {r.seed}: {r.error}" for results in runs.values() for r in results if r.error]
    if errors:
        raise SystemExit("errored episodes:\n" + "\n".join(errors))

    def outcomes(results: list[EpisodeResult]) -> dict[tuple, tuple]:
        return {(r.task, r.seed): (r.success, r.score, r.steps) for r in results}

    reproduced = outcomes(runs[modes[0][0]]) == outcomes(oracle)

    print(
        f"\nthe oracle's actions replayed by a slow openpi server (chunks of 10, open-loop horizon 8), "
        f"{args.episodes} seed(s) per task, episodes cut at {args.max_steps} steps; the synchronous replay "
        f"reproduces the oracle's episodes: {'yes' if reproduced else 'NO'}\n"
    )
    print("| task | mode | success | mean score | steps to success | held steps | queries | latency ms mean / max |")
    print("|---|---|---|---|---|---|---|---|")
    for task in args.tasks:
        for mode, results in runs.items():
            print(row(f"{task} | {mode}", [r for r in results if r.task == task]))
    for mode, results in runs.items():
        print(row(f"all | {mode}", results))
    print()
    for mode, results in runs.items():
        if results and results[0].held_steps is not None:
            held, steps = sum(r.held_steps for r in results), sum(r.steps for r in results)
            print(f"ratio of held steps to all steps, {mode}: {held / max(steps, 1):.2f}")
    print(f"\n{time.perf_counter() - started:.0f} s in all", file=sys.stderr)


if __name__ == "__main__":
    main()
