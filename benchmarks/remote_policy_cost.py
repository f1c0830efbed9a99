"""What the remote policy path costs on top of the env's own step.

The same policy (`hold`: answers at once) runs through the evaluation runner twice per round, on BananaInBowl with
two cameras at 320x180: in process, and behind `robolab serve` on this machine through `--policy openpi` with the
default open-loop horizon of 8 (one query per 8 steps: resize to 224x224, msgpack, websocket round trip). Printed:
wall time per control step of each, env step time, time per query, and the ratio remote / in process (target: at
most 1.10).

    .venv/bin/python benchmarks/remote_policy_cost.py [--steps 120] [--rounds 2]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import PolicyOptions, make_policy
from robolab_ms.policies.server import free_port, start_serve_process


def measure(policy_name: str, options: PolicyOptions, steps: int, seed: int, out: Path) -> dict[str, float]:
    config = EvalConfig(tasks=("BananaInBowl",), episodes=1, first_seed=seed, max_steps=steps)
    (result,) = run_evaluation(make_policy(policy_name, options), config, out, show_progress=False)
    assert result.error is None and result.steps == steps, result.error
    return {
        "step_ms": 1000.0 * result.wall_seconds / result.steps,
        "env_ms": result.env_step_ms,
        "query_ms": result.inference_ms_mean,
        "queries": result.queries,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=120, help="control steps per episode (default: 120)")
    parser.add_argument("--rounds", type=int, default=2, help="episodes of each path, interleaved (default: 2)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.rounds = 8, 1

    port = free_port()
    server = start_serve_process(["--policy", "hold"], port)
    remote_options = PolicyOptions(port=port, open_loop_horizon=8)
    rows: dict[str, list[dict[str, float]]] = {"in process": [], "robolab serve + openpi": []}
    try:
        with tempfile.TemporaryDirectory() as folder:
            for round_index in range(args.rounds):  # interleaved, so drift of the machine hits both alike
                start = time.perf_counter()
                rows["in process"].append(
                    measure("hold", PolicyOptions(), args.steps, round_index, Path(folder) / f"local{round_index}")
                )
                rows["robolab serve + openpi"].append(
                    measure("openpi", remote_options, args.steps, round_index, Path(folder) / f"remote{round_index}")
                )
                print(f"round {round_index + 1}/{args.rounds} done in {time.perf_counter() - start:.0f} s", flush=True)
    finally:
        server.terminate()
        server.wait(timeout=30)

    print(
        f"\nBananaInBowl, 2 cameras at 320x180, {args.steps} steps x {args.rounds} episodes per path, "
        "open-loop horizon 8"
    )
    print(f"{'path':26s} {'ms/step':>9s} {'env ms/step':>12s} {'ms/query':>9s} {'queries':>8s}")
    means = {}
    for name, measured in rows.items():
        means[name] = {key: float(np.mean([m[key] for m in measured])) for key in measured[0]}
        m = means[name]
        print(f"{name:26s} {m['step_ms']:9.1f} {m['env_ms']:12.1f} {m['query_ms']:9.2f} {m['queries']:8.0f}")
    remote, local = means["robolab serve + openpi"], means["in process"]
    print(
        f"\nper step beyond the env step: in process {local['step_ms'] - local['env_ms']:.1f} ms, "
        f"remote {remote['step_ms'] - remote['env_ms']:.1f} ms"
    )
    print(f"ratio remote / in process, wall time per step: {remote['step_ms'] / local['step_ms']:.3f} (target <= 1.10)")


if __name__ == "__main__":
    main()
