"""What the oracle's inverse kinematics costs against mplib's own, on the poses a placement search asks about.

The oracle asks inverse kinematics two kinds of question: a posture to move to (every distinct solution from its
starts, `MotionPlanner.ik`), and whether a pose is reached at all (`ik(..., first=True)`: `can_lower`, the place
samplers, the approach search), many of them out of reach. mplib's `Planner.IK` runs every start, also after a
solution is found; `MotionPlanner.flange_ik` runs the same closed-loop solver from the same starts and, for a test
of reach, stops at the first solution.

On one task's scene at reset (default FoodPackingByColor: two bins, one at the edge of the arm's reach), the script
draws top-down TCP poses over a box in front of the robot that reaches past the arm's reach, then alternates, in
one process, timed rounds of: mplib's IK, `ik` (all solutions) and `ik(first=True)` over the same poses, 20 starts
each. It prints the median seconds per round of each, their ratios to mplib's, and how often each found the pose
reached where mplib did.

    .venv/bin/python benchmarks/ik_cost.py [--task FoodPackingByColor] [--poses 60] [--rounds 3]
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
    parser.add_argument("--task", default="FoodPackingByColor", help="task whose scene (at seed 0) the arm is in")
    parser.add_argument("--poses", type=int, default=60, help="TCP poses asked about per round")
    parser.add_argument("--rounds", type=int, default=3, help="timed rounds of each kind")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.poses, args.rounds = 2, 1

    import mani_skill.envs  # noqa: F401 (registers ManiSkill's environments)
    from helpers import oracle_at_reset

    import robolab_ms.envs  # noqa: F401 (registers the tasks)
    from robolab_ms.policies.oracle.geometry import down_quaternion
    from robolab_ms.policies.oracle.motion import IK_STARTS, seed_planner

    rng = np.random.default_rng(0)
    with oracle_at_reset(args.task, 0) as (_, oracle):
        motion = oracle.motion
        start = motion.current_qpos()
        poses = []
        for _ in range(args.poses):  # over the table from near the base to past the reach, hand turned at random
            xyz = [rng.uniform(0.3, 0.95), rng.uniform(-0.5, 0.5), rng.uniform(0.1, 0.5)]
            turn = rng.uniform(-np.pi / 2, np.pi / 2)
            poses.append(np.concatenate([xyz, down_quaternion(np.array([np.cos(turn), np.sin(turn)]))]))

        def mplib_ik(pose: np.ndarray) -> bool:
            return motion.planner.IK(motion.flange_target(pose), start, n_init_qpos=IK_STARTS)[0] == "Success"

        def every(pose: np.ndarray) -> bool:
            return motion.ik(pose, start)[0] == "Success"

        def first(pose: np.ndarray) -> bool:
            return motion.ik(pose, start, first=True)[0] == "Success"

        kinds = {"mplib IK": mplib_ik, "ik": every, "ik(first=True)": first}
        seconds: dict[str, list[float]] = {name: [] for name in kinds}
        reached: dict[str, list[bool]] = {}
        for _ in range(args.rounds):
            for name, solve in kinds.items():
                seed_planner(0)
                began = time.perf_counter()
                reached[name] = [solve(pose) for pose in poses]
                seconds[name].append(time.perf_counter() - began)

    base = statistics.median(seconds["mplib IK"])
    print(f"{args.task}: {args.poses} poses, {sum(reached['mplib IK'])} reached by mplib's IK")
    for name in kinds:
        agree = np.mean(np.equal(reached[name], reached["mplib IK"]))
        print(
            f"{name:16s} {statistics.median(seconds[name]):7.3f} s per round, ratio {statistics.median(seconds[name]) / base:.3f}, "
            f"same answer as mplib's on {agree:.0%} of the poses"
        )


if __name__ == "__main__":
    main()
