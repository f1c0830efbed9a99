"""The oracle's check of a reach's real way: the joint-space path to the pose over a grasp, not its straight line.

`OraclePolicy._reach_over` raises the hand over what stands near the straight line from where the hand is to the
pose over the next grasp. The move itself is a joint-space path, whose TCP can run centimetres below that line:
leaving a crate after a drop, high over it, the open fingers swept down across its near wall, caught its rim and
pulled the crate over onto the next object (RecycleCarton, seeds 4 and 6). Where the planned path brings the open
fingers level with or below the top of another object's surface right under them, the reach goes over the grasp at
a height that clears what is near the way and comes straight down, as it does where the straight line is too low.
A path that passes above everything, however closely, is kept as it was.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.policies.oracle import OraclePolicy

SAG_REACH = 0.075  # m: object points this near the TCP (horizontally) are under the open fingers (their outer ends)
SAG_MARGIN = 0.005  # m: the fingertips passing less than this above such a point catch on it


def sagging_reach_height(policy: OraclePolicy, first_action: int, name: str) -> float | None:
    """For the reach queued from action `first_action` on, towards object `name`: None where the open fingertips
    stay above every other object's surface under them all the way; else the TCP height over the grasp from which
    the hand passes TRAVEL_CLEARANCE above everything near the way (as `_pass_height` measures it, along the path
    the arm really takes)."""
    import sapien

    from robolab_ms.policies.oracle import (
        FINGERTIP_BELOW_TCP,
        FLANGE_LINK,
        PASS_RADIUS,
        TRAVEL_CLEARANCE,
        _world_points,
    )

    env, planner = policy.env, policy._planner
    model, flange = planner.pinocchio_model, planner.link_name_2_idx[FLANGE_LINK]
    actions = list(policy.actions)[first_action:]
    if not actions:
        return None
    joints = policy._planner_qpos()
    way = []
    for action in actions:
        joints[:7] = action[:7]
        model.compute_forward_kinematics(joints)
        pose = np.asarray(model.get_link_pose(flange))
        way.append((sapien.Pose(p=pose[:3], q=pose[3:]) * policy._tcp_in_flange).p)
    way = np.asarray(way, dtype=np.float64)  # (steps, 3): the TCP along the path
    snag, highest = False, -np.inf
    for other in env.objects:
        if other == name:
            continue
        points = _world_points(env, other)
        distance = np.linalg.norm(points[None, :, :2] - way[:, None, :2], axis=2)  # (steps, points)
        under = distance < SAG_REACH
        if under.any():
            tops = np.where(under, points[None, :, 2], -np.inf).max(axis=1)
            snag = snag or bool((way[:, 2] - FINGERTIP_BELOW_TCP - SAG_MARGIN < tops).any())
        near = distance < PASS_RADIUS
        if near.any():
            highest = max(highest, float(points[near.any(axis=0), 2].max()))
    if not snag:
        return None
    return highest + TRAVEL_CLEARANCE + FINGERTIP_BELOW_TCP
