"""What the oracle's check that the hand keeps clear of the fixtures (`gripper.hand_clear`) costs, against the plain
check it replaced, on one task's shelf.

The oracle checks the hand's solids against the fixtures' boxes at every waypoint of a straight move and at every
posture it tries beside a shelf. The plain check built the hand's sample points anew for every pose and tested them
against every box; `hand_clear` builds them once (`gripper.hand_samples`) and skips a box where the ball round the
points misses the ball round the grown box (`geometry.inside_boxes`). On the task's scene at reset (default
JugsOnShelf: a rack of 6 boxes), the script draws top-down hand poses over the table and the shelf, then alternates,
in one process, timed rounds of both checks over the same poses. It prints each round's seconds, their ratio (new /
plain) and whether the two gave the same answer for every pose.

    .venv/bin/python benchmarks/hand_clear_cost.py [--task JugsOnShelf] [--poses 2000] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))


def plain_hand_points(pose: np.ndarray) -> np.ndarray:
    """The hand's sample points at TCP `pose`, built anew (the check before `gripper.hand_samples`)."""
    from robolab_ms.policies.oracle.geometry import quat_to_matrix
    from robolab_ms.policies.oracle.gripper import HAND_SAMPLE, HAND_SOLIDS

    local = []
    for half_x, half_y, z_from, z_to in HAND_SOLIDS:
        axes = [np.linspace(-h, h, max(2, int(np.ceil(2 * h / HAND_SAMPLE)) + 1)) for h in (half_x, half_y)]
        zs = np.linspace(z_from, z_to, max(2, int(np.ceil((z_to - z_from) / HAND_SAMPLE)) + 1))
        local.append(np.stack(np.meshgrid(*axes, zs), axis=-1).reshape(-1, 3))
    return np.concatenate(local) @ quat_to_matrix(pose[3:]).T + pose[:3]


def plain_hand_clear(pose: np.ndarray, boxes: list, margin: float) -> bool:
    """Every sample point tested against every box."""
    points = plain_hand_points(pose)
    return not any(
        bool(np.any(np.all(np.abs((points - centre) @ rotation) <= half + margin, axis=1)))
        for rotation, centre, half in boxes
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--task", default="JugsOnShelf", help="task whose fixtures (at seed 0) the hand is checked against"
    )
    parser.add_argument("--poses", type=int, default=2000, help="hand poses per round")
    parser.add_argument("--rounds", type=int, default=3, help="timed rounds of each check")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.poses, args.rounds = 5, 1

    import mani_skill.envs  # noqa: F401 (registers ManiSkill's environments)
    from helpers import task_at_reset

    import robolab_ms.envs  # noqa: F401 (registers the tasks)
    from robolab_ms.policies.oracle.geometry import down_quaternion
    from robolab_ms.policies.oracle.gripper import HAND_FIXTURE_MARGIN, hand_clear
    from robolab_ms.policies.oracle.world import fixture_boxes

    rng = np.random.default_rng(0)
    with task_at_reset(args.task, 0) as env:
        boxes = fixture_boxes(env)
    down = down_quaternion(np.array([1.0, 0.0]))
    poses = [
        np.concatenate([[rng.uniform(0.3, 0.8), rng.uniform(-0.4, 0.4), rng.uniform(0.05, 0.7)], down])
        for _ in range(args.poses)
    ]
    plain_seconds, new_seconds, same = [], [], True
    for _ in range(args.rounds):
        began = time.perf_counter()
        plain = [plain_hand_clear(pose, boxes, HAND_FIXTURE_MARGIN) for pose in poses]
        plain_seconds.append(time.perf_counter() - began)
        began = time.perf_counter()
        new = [hand_clear(pose, boxes) for pose in poses]
        new_seconds.append(time.perf_counter() - began)
        same = same and plain == new
    plain_median, new_median = statistics.median(plain_seconds), statistics.median(new_seconds)
    print(f"{args.task}: {len(boxes)} fixture boxes, {args.poses} poses, {sum(new)} clear")
    print(f"plain check {plain_median:.3f} s, hand_clear {new_median:.3f} s per round")
    print(f"ratio hand_clear / plain: {new_median / plain_median:.3f}; same answer for every pose: {same}")


if __name__ == "__main__":
    main()
