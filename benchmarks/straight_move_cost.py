"""What the oracle's straight moves cost (`MotionPlanner.straight_waypoints`) with the flange's orientation at every
waypoint interpolated in one call of scipy's Slerp, against one call per waypoint (the baseline: how the oracle did
it before; each call costs about as much as a waypoint's inverse kinematics).

Both give the same orientations to the last bit, so the same waypoints. On the task's scene at reset (default
ReorientRedMug, whose mug is turned over by long straight moves), the script draws straight moves of the flange from
the arm's posture at reset to poses over the table, each turned about the vertical and tilted, then alternates, in
one process, timed rounds of both ways over the same moves. It prints each way's seconds per round, their ratio and
whether every move gave the same waypoints both ways.

    .venv/bin/python benchmarks/straight_move_cost.py [--task ReorientRedMug] [--moves 60] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="ReorientRedMug", help="task whose scene (at seed 0) the arm moves over")
    parser.add_argument("--moves", type=int, default=60, help="straight moves per round")
    parser.add_argument("--rounds", type=int, default=3, help="timed rounds of each way")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.moves, args.rounds = 2, 1

    import mani_skill.envs  # noqa: F401 (registers ManiSkill's environments)
    import scipy.spatial.transform as transform
    from helpers import task_at_reset
    from scipy.spatial.transform import Rotation, Slerp

    import robolab_ms.envs  # noqa: F401 (registers the tasks)
    from robolab_ms.policies.oracle.geometry import down_quaternion
    from robolab_ms.policies.oracle.motion import MotionPlanner

    class SlerpOneAtATime(Slerp):
        """The baseline: scipy's Slerp evaluated once per time asked for."""

        def __call__(self, times):
            return Rotation.concatenate([Slerp.__call__(self, time) for time in np.atleast_1d(times)])

    rng = np.random.default_rng(0)
    with task_at_reset(args.task, 0) as env:
        motion = MotionPlanner(env)
        motion.bind(env)
        motion.sync_fixtures()
        start = motion.current_qpos()
        goals = []
        for _ in range(args.moves):
            down = down_quaternion(np.array([np.cos(turn := rng.uniform(0.0, np.pi)), np.sin(turn)]))
            tilt = Rotation.from_rotvec(rng.uniform(-0.4, 0.4, 3)) * Rotation.from_quat(np.roll(down, -1))
            place = [rng.uniform(0.35, 0.65), rng.uniform(-0.3, 0.3), rng.uniform(0.15, 0.4)]
            goals.append(motion.flange_target(np.concatenate([place, np.roll(tilt.as_quat(), 1)])))
        seconds: dict[str, list[float]] = {"one call": [], "one call per waypoint": []}
        found: dict[str, list] = {}
        for _ in range(args.rounds):
            for way, slerp in (("one call", Slerp), ("one call per waypoint", SlerpOneAtATime)):
                transform.Slerp = slerp
                try:
                    began = time.perf_counter()
                    found[way] = [motion.straight_waypoints(goal, start) for goal in goals]
                    seconds[way].append(time.perf_counter() - began)
                finally:
                    transform.Slerp = Slerp
    ways = list(seconds)
    same = all(
        (a is None and b is None) or (a is not None and b is not None and np.array_equal(a, b))
        for a, b in zip(found[ways[0]], found[ways[1]], strict=True)
    )
    moved = sum(path is not None for path in found[ways[0]])
    waypoints = sum(len(path) for path in found[ways[0]] if path is not None)
    ours, baseline = (statistics.median(seconds[way]) for way in ways)
    print(f"{args.task}: {args.moves} straight moves, {moved} found ({waypoints} waypoints)")
    print(f"orientations in one call {ours:.3f} s, one call per waypoint {baseline:.3f} s per round")
    print(f"ratio one call / one call per waypoint: {ours / baseline:.3f}; same waypoints for every move: {same}")


if __name__ == "__main__":
    main()
