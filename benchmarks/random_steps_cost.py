"""What a random-policy control step of `robolab validate` costs with its quiet steps, against one whose gripper
command ends them, in one environment.

The task logic returns the previous step's result while nothing has moved (quiet steps,
robolab_ms/tasks/evaluator.py). Where events are tracked, the gripper's closed fraction crossing an event threshold
ends a run of quiet steps; the random policy draws a new gripper command at every step, so with events on most of
its steps are evaluated in full. `robolab validate` runs its random episodes with events off, where the fraction
does not count. On one task's validation environment (no observations), the script alternates timed blocks of
random steps with events off (as validation runs them) and the baseline (the gripper's fraction counted, as where
events are on, but no event detected: validation's random steps before the change), and prints for each the milliseconds per step and the share of quiet steps, and their ratio.

    .venv/bin/python benchmarks/random_steps_cost.py [--task ClutterPlastic] [--steps 300] [--rounds 5]
"""

from __future__ import annotations

import argparse
import statistics
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="ClutterPlastic", help="task whose validation environment is stepped")
    parser.add_argument("--steps", type=int, default=300, help="random steps per timed block")
    parser.add_argument("--rounds", type=int, default=5, help="timed blocks of each kind")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.rounds = 3, 1

    import numpy as np

    from robolab_ms.eval.validate import validation_config, validation_env
    from robolab_ms.tasks.spec import load_task

    spec = load_task(args.task)
    env = validation_env(str(spec.file), validation_config((str(spec.file),), 1, 0, None))
    env.reset(seed=0)
    evaluator = env.unwrapped.task_evaluator
    space = env.action_space
    rng = np.random.default_rng(0)
    for _ in range(60):  # the objects settle after reset
        env.step(rng.uniform(space.low, space.high).astype(np.float32))

    detect_events = evaluator.events.update

    def block(track_events: bool) -> tuple[float, float]:
        # the baseline counts the gripper's fraction (events on) but detects no event, as validation did before
        evaluator.track_events = track_events
        evaluator.events.update = (
            (lambda targets, closed: evaluator.events.nothing_fired) if track_events else detect_events
        )
        quiet_before, began = evaluator.quiet_steps, time.perf_counter()
        for _ in range(args.steps):
            env.step(rng.uniform(space.low, space.high).astype(np.float32))
        seconds = time.perf_counter() - began
        return seconds / args.steps * 1000, (evaluator.quiet_steps - quiet_before) / args.steps

    off, on = [], []
    for _ in range(args.rounds):
        off.append(block(False))
        on.append(block(True))
    env.close()
    off_ms, on_ms = statistics.median(ms for ms, _ in off), statistics.median(ms for ms, _ in on)
    print(f"{args.task}: {args.rounds} blocks of {args.steps} random steps each way")
    print(f"events off (validation):    {off_ms:.2f} ms per step, {statistics.mean(q for _, q in off):.0%} quiet")
    print(f"baseline (fraction counted): {on_ms:.2f} ms per step, {statistics.mean(q for _, q in on):.0%} quiet")
    print(f"ratio events off / baseline: {off_ms / on_ms:.3f}")


if __name__ == "__main__":
    main()
