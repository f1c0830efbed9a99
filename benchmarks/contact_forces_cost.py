"""What the task logic's contact forces cost on the CPU simulator (`EvalContext._cpu_forces`, one pass over PhysX's
contacts summing the impulses of the pairs it needs in Python floats), against the same pass summing them with
numpy arrays (the baseline: how it was done before; each numpy call on three numbers costs more than the sum).

Both give the same numbers to the last bit. The script runs the oracle on a task (default DishesInBin, seed 1)
and, after every control step, times both ways on the same contacts (with one object-table pair asked for, as
`force_on` adds it), checks that they agree exactly, and prints the milliseconds per call of each and their ratio.

    .venv/bin/python benchmarks/contact_forces_cost.py [--task DishesInBin] [--seed 1] [--steps 400]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))


def numpy_sums(context) -> dict:
    """The baseline: `_cpu_forces` summing each contact's impulses into numpy arrays."""
    impulses: dict = {}
    names, fingers, wanted = context._body_names, context._fingers, context._wanted_pairs
    for contact in context.scene.px.get_contacts():
        bodies = contact.bodies
        a, b = names.get(bodies[0]), names.get(bodies[1])
        if a is None or b is None or a == b:
            continue
        if a not in fingers and b not in fingers and ((a, b) if a <= b else (b, a)) not in wanted:
            continue
        total = np.zeros(3)
        for point in contact.points:
            total += point.impulse
        key, sign = ((a, b), 1.0) if a <= b else ((b, a), -1.0)
        impulses[key] = impulses.get(key, 0.0) + sign * total
    return {key: value / context.scene.px.timestep for key, value in impulses.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="DishesInBin", help="task the oracle runs")
    parser.add_argument("--seed", type=int, default=1, help="the episode's seed")
    parser.add_argument("--steps", type=int, default=400, help="control steps of the oracle's episode")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.steps = 5

    import mani_skill.envs  # noqa: F401 (registers ManiSkill's environments)
    from helpers import oracle_at_reset

    import robolab_ms.envs  # noqa: F401 (registers the tasks)

    ours_seconds = baseline_seconds = 0.0
    same = True
    with oracle_at_reset(args.task, args.seed) as (env, oracle):
        context = env.eval_context
        context._wanted_pairs.add(tuple(sorted((next(iter(env.objects)), "table"))))
        for _ in range(args.steps):
            env.step(oracle.act(None))
            began = time.perf_counter()
            ours = context._cpu_forces()
            ours_seconds += time.perf_counter() - began
            began = time.perf_counter()
            baseline = numpy_sums(context)
            baseline_seconds += time.perf_counter() - began
            same = same and ours.keys() == baseline.keys()
            same = same and all(np.array_equal(ours[key], baseline[key]) for key in ours)
    ours_ms, baseline_ms = (seconds / args.steps * 1000 for seconds in (ours_seconds, baseline_seconds))
    print(f"{args.task} seed {args.seed}: {args.steps} oracle steps")
    print(f"sums in Python floats {ours_ms:.3f} ms, in numpy arrays {baseline_ms:.3f} ms per call")
    print(f"ratio Python floats / numpy: {ours_ms / baseline_ms:.3f}; the same forces at every step: {same}")


if __name__ == "__main__":
    main()
