"""The oracle's holds of heavy and long tools: higher up where the widest part is walled in (a drill standing in a
bin), and drawn nearer the robot before it is lifted where it is at the edge of the arm's reach.

grasp_pose holds an object at the widest section that fits between the open fingers, lower down where it is wider
(round things through their middle). A drill standing in a bin is widest at its battery, down by the bin's floor,
where the open fingers would meet the bin's walls, and grasp_pose would turn the hand to close along the drill's
length, on no part that fits. Such a tool is held higher up instead, GRASP_DEPTH below its top (a drill across
its body, over its centre of mass), where the fingers clear the walls.

A tool held over its centre of mass more than TOOL_REACH from the robot's base (a drill at the back of a bin) can be
grasped, but the arm cannot go APPROACH_HEIGHT above it nor lift it straight out (held off its centre of mass, it
turns in the pads): the hand comes down from a lower pose, drawn back towards the robot where that one is out of
reach too, and once it holds the tool it draws it nearer, just off the floor, before it lifts it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv
    from robolab_ms.policies.oracle import OraclePolicy


TOOL_REACH = 0.765  # m from the robot's base (horizontally) within which the arm lifts a tool held from above
APPROACH_STEP = 0.01  # m between the heights tried for the pose a far tool is reached from ...
APPROACH_LOWEST = 0.03  # ... down to this far above the grasp ...
APPROACH_BACKS = (0.0, 0.02, 0.04)  # ... at each height first over the grasp, then drawn back this far (m)
DRAW_RISE = 0.01  # m a far tool is raised off the floor while it is drawn nearer ...
DRAW_MAX = 0.05  # ... by at most this far


def far_tool(env: RoboLabEnv, name: str, grasp: np.ndarray) -> bool:
    """Whether object `name` is a heavy or long tool and `grasp` (a TCP pose, robot frame) is beyond TOOL_REACH from
    the robot's base (horizontally)."""
    from robolab_ms.policies.oracle import _heavy, _tool, _world_points

    if float(np.linalg.norm(grasp[:2])) <= TOOL_REACH:
        return False
    return _heavy(env, name) or _tool(env, name, _world_points(env, name))


def reachable_above(policy: OraclePolicy, grasp: np.ndarray, above: np.ndarray) -> np.ndarray:
    """The pose a far tool's grasp is come down to from: `above` where the arm reaches it (inverse kinematics),
    else the highest pose down to APPROACH_LOWEST over the grasp that it reaches, over the grasp or drawn back
    towards the robot by one of APPROACH_BACKS; `above` where none is reached (the planner then says why)."""
    from robolab_ms.policies.oracle import IK_RETRIES

    toward = -grasp[:2] / np.linalg.norm(grasp[:2])
    for height in np.arange(above[2], grasp[2] + APPROACH_LOWEST - 1e-6, -APPROACH_STEP):
        for back in APPROACH_BACKS:
            pose = grasp.copy()
            pose[:2] += toward * back
            pose[2] = height
            status, _ = policy._planner.IK(policy._flange_target(pose), policy._planner_qpos(), n_init_qpos=IK_RETRIES)
            if status == "Success":
                return pose
    return above


def draw_nearer(policy: OraclePolicy, qpos: np.ndarray, grasp: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Queue a straight move of the hand holding a far tool (grasped at `grasp`) towards the robot, to TOOL_REACH
    (at most DRAW_MAX) and DRAW_RISE up; returns the final joints and the TCP pose there (`qpos` and `grasp` where
    that move cannot be planned)."""
    from robolab_ms.policies.oracle import OracleFailure

    distance = float(np.linalg.norm(grasp[:2]))
    nearer = grasp.copy()
    nearer[:2] *= max(TOOL_REACH, distance - DRAW_MAX) / distance
    nearer[2] += DRAW_RISE
    planned = len(policy.actions)
    try:
        return policy._move(qpos, nearer, f"draw '{name}' nearer"), nearer
    except OracleFailure:
        while len(policy.actions) > planned:
            policy.actions.pop()
        return qpos, grasp


Hold = tuple[float, float, float, float]  # TCP height, width closed on, fingers' clash, the rest of the hand's clash


def higher_hold(
    slab: np.ndarray, closing: np.ndarray, heights: tuple[np.ndarray, np.ndarray] | None, xy: np.ndarray, lower: Hold
) -> Hold:
    """A top-down hold of a tool at (x, y) `xy`, the fingers closing along `closing` (horizontal unit vector),
    GRASP_DEPTH below the top of `slab` (the tool's world points between the fingers): the TCP height, the width
    the fingers close on there (the slab from just below that height up), and how far anything else rises into
    the space of the fingers and of the rest of the hand (`_hand_clash` of the oracle's obstacle grid `heights`).
    `lower` (the hold grasp_pose found, in the same terms) where that one is not lower (a flat tool)."""
    from robolab_ms.policies.oracle import GRASP_DEPTH, SECTION_STEP, _hand_clash

    z = float(slab[:, 2].max()) - GRASP_DEPTH
    if z <= lower[0] + SECTION_STEP:
        return lower
    section = slab[slab[:, 2] >= z - 2 * SECTION_STEP]
    width = float(np.ptp(section[:, :2] @ closing)) if len(section) >= 2 else 0.0
    fingers, body = _hand_clash(heights, xy, closing, z)
    return z, width, fingers, body
