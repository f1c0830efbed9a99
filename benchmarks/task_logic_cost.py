"""What the task logic (predicates, subtask progress, events) adds to a state-only step of a 20-object scene.

Alternates, in one process, timed blocks of steps of the same environment with its real evaluate() and with an
empty one, and prints the per-step times and their ratio (target: at most 1.10), in two situations:

- resting: the arm holds still and every object rests (PhysX puts them to sleep). This is most of an episode for
  most objects, and the task logic takes its quiet-step path (robolab_ms/tasks/evaluator.py).
- in full: every object is woken before each step, so every step is evaluated in full: the worst case, as when
  the arm pushes through the whole scene.

    .venv/bin/python benchmarks/task_logic_cost.py [--steps 300] [--rounds 7]
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
    parser.add_argument("--rounds", type=int, default=7, help="timed blocks of each kind per situation")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.rounds = 2, 1

    env = RoboLabEnv(task=str(TASK), obs_mode="state", render_backend="cpu")
    env.reset(seed=0)
    action = np.concatenate([env.arm_qpos()[0].numpy(), [0.0]]).astype(np.float32)
    bodies = [body for body in env.eval_context._free_bodies]
    real_evaluate = env.evaluate
    nothing = torch.zeros(env.num_envs, dtype=torch.bool)

    def empty_evaluate() -> dict:
        return dict(success=nothing, fail=nothing)

    def block(evaluate, wake: bool) -> float:
        env.evaluate = evaluate
        start = time.perf_counter()
        for _ in range(args.steps):
            if wake:
                for body in bodies:
                    body.wake_up()
            env.step(action)
        return (time.perf_counter() - start) / args.steps * 1000

    print(f"scene objects: {len(env.objects)}, steps per block: {args.steps}, rounds: {args.rounds}")
    for situation, wake in (("resting", False), ("in full", True)):
        block(real_evaluate, wake), block(empty_evaluate, wake)  # warm-up; lets the resting scene fall asleep
        quiet_before = env.task_evaluator.quiet_steps
        ratios, with_logic, without = [], [], []
        for _ in range(args.rounds):
            a, b = block(real_evaluate, wake), block(empty_evaluate, wake)
            with_logic.append(a), without.append(b), ratios.append(a / b)
        quiet = (env.task_evaluator.quiet_steps - quiet_before) / (args.rounds * args.steps)
        print(f"\n{situation}: {quiet:.0%} of the evaluations took the quiet-step path")
        print(f"  step with task logic:     median {statistics.median(with_logic):.3f} ms")
        print(f"  step with empty evaluate: median {statistics.median(without):.3f} ms")
        print(
            f"  ratio (target <= 1.10):   median {statistics.median(ratios):.3f}"
            f"  (min {min(ratios):.3f}, max {max(ratios):.3f})"
        )


if __name__ == "__main__":
    main()
