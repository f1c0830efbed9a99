"""What the oracle's tests of reach cost with its own inverse kinematics (`MotionPlanner.flange_ik`, stopping at the
first posture found and not searching poses its geometry rules out, `reach.ArmReach`), against mplib's
`Planner.IK`, which runs every random start to the end.

Both draw the same random starts (from the C library's generator, seeded by `motion.seed_planner`), so they answer
the same for every pose, and the posture the oracle keeps (the first found) is the same. On the task's scene at
reset (default BlackItemsInBin), the script draws top-down TCP poses over the table, some out of the arm's reach,
then alternates, in one process, timed rounds of both over the same poses, each round from the same seed. It prints
each round's seconds, their ratio (flange_ik / mplib) and whether both answered the same for every pose.

    .venv/bin/python benchmarks/reach_test_cost.py [--task BlackItemsInBin] [--poses 200] [--rounds 3]

Where the pose is reachable the first start usually finds a posture and the other 19 are skipped; where it is out
of reach mplib runs every start's 1,000 iterations, and flange_ik none where the arm's geometry rules the pose out
(those within the geometric reach but unreachable, by joint limits or the turn of the hand, still run them all).
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
    parser.add_argument("--task", default="BlackItemsInBin", help="task whose scene (at seed 0) the arm reaches into")
    parser.add_argument("--poses", type=int, default=200, help="TCP poses per round")
    parser.add_argument("--rounds", type=int, default=3, help="timed rounds of each")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.poses, args.rounds = 4, 1

    import mani_skill.envs  # noqa: F401 (registers ManiSkill's environments)
    from helpers import task_at_reset

    import robolab_ms.envs  # noqa: F401 (registers the tasks)
    from robolab_ms.policies.oracle.geometry import down_quaternion
    from robolab_ms.policies.oracle.motion import MotionPlanner, any_posture, seed_planner

    rng = np.random.default_rng(0)
    with task_at_reset(args.task, 0) as env:
        motion = MotionPlanner(env)
        motion.bind(env)
        motion.sync_fixtures()
        start = motion.current_qpos()
        flanges = [
            motion.flange_target(
                np.concatenate(
                    [
                        [rng.uniform(0.2, 1.0), rng.uniform(-0.6, 0.6), rng.uniform(0.05, 0.6)],
                        down_quaternion(np.array([np.cos(turn), np.sin(turn)])),
                    ]
                )
            )
            for turn in rng.uniform(0.0, np.pi, args.poses)
        ]
        mplib_seconds, own_seconds, same = [], [], True
        for _ in range(args.rounds):
            seed_planner(0)
            began = time.perf_counter()
            mplib = [motion.planner.IK(flange, start) for flange in flanges]
            mplib_seconds.append(time.perf_counter() - began)
            seed_planner(0)
            began = time.perf_counter()
            own = [motion.flange_ik(flange, start, serves=any_posture) for flange in flanges]
            own_seconds.append(time.perf_counter() - began)
            for (mplib_status, mplib_found), (own_status, own_found) in zip(mplib, own):
                same = same and (mplib_status == "Success") == (own_status == "Success")
                same = same and (not mplib_found or np.allclose(mplib_found[0], own_found[0]))
    reached = sum(status == "Success" for status, _ in own)
    mplib_median, own_median = statistics.median(mplib_seconds), statistics.median(own_seconds)
    print(f"{args.task}: {args.poses} poses, {reached} in reach")
    print(f"mplib IK {mplib_median:.3f} s, flange_ik (first posture) {own_median:.3f} s per round")
    print(f"ratio flange_ik / mplib: {own_median / mplib_median:.3f}; same answer and posture for every pose: {same}")


if __name__ == "__main__":
    main()
