"""What the task logic (predicates, subtask progress, events) adds to a state-only step of a 20-object scene.

Alternates, in one process, blocks of steps of the same environment with its real evaluate() and with an empty one,
and prints the per-step times and their ratio (target: at most 1.10).

    .venv/bin/python benchmarks/task_logic_cost.py [--steps 300] [--rounds 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import torch

from robolab_ms.envs import RoboLabEnv

TASK = Path(__file__).parent / "fixtures" / "TwentyObjects.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=300, help="control steps per timed block")
    parser.add_argument("--rounds", type=int, default=5, help="timed blocks of each kind")
    args = parser.parse_args()

    env = RoboLabEnv(task=str(TASK), obs_mode="state", render_backend="cpu")
    env.reset(seed=0)
    action = np.concatenate([env.agent.robot.get_qpos()[0, :7].numpy(), [0.0]]).astype(np.float32)
    real_evaluate = env.evaluate
    nothing = torch.zeros(env.num_envs, dtype=torch.bool)

    def empty_evaluate() -> dict:
        return dict(success=nothing, fail=nothing)

    def block(evaluate) -> float:
        env.evaluate = evaluate
        start = time.perf_counter()
        for _ in range(args.steps):
            env.step(action)
        return (time.perf_counter() - start) / args.steps * 1000

    block(real_evaluate), block(empty_evaluate)  # warm-up
    ratios, with_logic, without = [], [], []
    for _ in range(args.rounds):
        a, b = block(real_evaluate), block(empty_evaluate)
        with_logic.append(a), without.append(b), ratios.append(a / b)
    print(f"scene objects: {len(env.objects)}, steps per block: {args.steps}, rounds: {args.rounds}")
    print(f"step with task logic:    median {statistics.median(with_logic):.3f} ms")
    print(f"step with empty evaluate: median {statistics.median(without):.3f} ms")
    print(f"ratio (target <= 1.10):   median {statistics.median(ratios):.3f}  (min {min(ratios):.3f}, max {max(ratios):.3f})")


if __name__ == "__main__":
    main()
