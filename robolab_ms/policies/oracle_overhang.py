"""The oracle's side-step descent: a top-down grasp next to something that overhangs it (a keyboard leaning over a
bin's rim above a phone lying beside the bin).

Coming straight down, an open finger would pass through the overhanging part, although at the grasp itself the
fingers are well below it. The hand then comes down beside the grasp, stepped away from the overhang along the
closing direction, to just above the object's top, moves in sideways under the overhang and goes down the last
centimetres; after closing it goes the same way back out before it lifts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.catalog.procedural import quat_to_matrix

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

STEP_DISTANCES = (0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.04, 0.05)  # m the hand may step aside, least first
FINGER_TOP = 0.10  # m above the TCP that the open fingers reach (above it: the gripper's body, narrower)
PAD_BELOW_TCP = 0.006  # m the open pads reach below the TCP
STEP_CLEARANCE = 0.006  # m between the open pads and the object's top while the hand moves in sideways
OVERHANG_MARGIN = 0.01  # m kept between the top of the open fingers and the underside of an overhang
UNDERSIDE_START = 0.001  # m above the table where the rays that find undersides start
# Under an overhang the gripper's body and the coupling to the arm (3.8 cm in radius) are in the way within this far of
# the TCP (the planner's grasp search keeps a wider, 6 cm box clear for the wrist)
WRIST_HALF = 0.045
STEP_SETTLE_STEPS = 12  # control steps held after moving in, for the arm to catch up before the last descent
STEP_LIFT = 0.01  # m the held object is raised off the table before the hand moves back out sideways


def side_step(
    env: RoboLabEnv,
    name: str,
    xy: np.ndarray,
    closing: np.ndarray,
    z: float,
    heights: tuple[np.ndarray, np.ndarray] | None,
) -> np.ndarray | None:
    """The horizontal offset (x, y) of the pose above a top-down grasp of `name` at (xy, z), fingers closing along
    `closing`, from which the hand comes in sideways under an overhang (see the module's docstring); None where
    the way straight down is clear, where something other than an overhang high enough is in the fingers' way, or
    where no step of at most the largest of STEP_DISTANCES clears it. `heights`: the obstacle grid of the oracle's
    grasp search (None off the CPU simulator)."""
    from robolab_ms.policies import oracle

    if heights is None:
        return None
    cells, tops = heights
    closing = np.asarray(closing[:2], dtype=np.float64) / np.linalg.norm(closing[:2])
    along = np.array([-closing[1], closing[0]])
    half_u, half_v, reach = oracle.HAND_PARTS[0]
    local = cells - xy
    u, v = np.abs(local @ along), local @ closing
    margin = oracle.HAND_MARGIN
    in_way = (u <= half_u + margin) & (np.abs(v) <= half_v + margin) & (tops > z - reach)
    if not in_way.any():
        return None
    body = (u <= WRIST_HALF + margin) & (np.abs(v) <= WRIST_HALF + margin) & (tops > z + oracle.HAND_PARTS[1][2])
    if body.any():  # the gripper's body or the wrist over the grasp would hit it: no way in
        return None
    sides = np.sign(v[in_way])
    if np.any(sides != sides[0]) or sides[0] == 0.0:  # on both sides of the hand
        return None
    points = oracle._world_points(env, name)
    low = max(z, float(points[:, 2].max()) + PAD_BELOW_TCP + STEP_CLEARANCE)
    if undersides(env, name, cells[in_way]).min() < low + FINGER_TOP + OVERHANG_MARGIN:
        return None  # not an overhang, or one too low to reach under
    away = -sides[0] * closing
    for distance in STEP_DISTANCES:
        if oracle._hand_clash(heights, xy + away * distance, closing, low) == (0.0, 0.0):
            return away * distance
    return None


def side_step_path(env: RoboLabEnv, name: str, grasp: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """For the top-down grasp `grasp` [x, y, z, qw, qx, qy, qz] of `name`: the TCP pose beside it from which the
    hand comes in sideways, and the pose just above the grasp it moves in to (both at the height where the open
    pads clear the object's top); None where the hand comes straight down."""
    from robolab_ms.policies import oracle

    rotation = quat_to_matrix(grasp[3:])
    if abs(rotation[2, 2] + 1.0) > 1e-3:  # only a hand pointing straight down
        return None
    heights = oracle._obstacle_heights(env, name, grasp[:2])
    offset = side_step(env, name, grasp[:2], rotation[:2, 1], float(grasp[2]), heights)
    if offset is None:
        return None
    points = oracle._world_points(env, name)
    low = max(float(grasp[2]), float(points[:, 2].max()) + PAD_BELOW_TCP + STEP_CLEARANCE)
    over = grasp.copy()
    over[2] = low
    beside = over.copy()
    beside[:2] += offset
    return beside, over


def undersides(env: RoboLabEnv, name: str, cells: np.ndarray) -> np.ndarray:
    """The height of the first thing above the table (the robot and `name` aside) that an upward ray meets at each
    of `cells` (K, 2): 0 where something stands on the table there, inf where nothing is above."""
    owner = {entity: other for other, actor in env.objects.items() for entity in actor._objs}
    up = np.array([0.0, 0.0, 1.0], dtype=np.float32)
    found = np.full(len(cells), np.inf)
    for index, (x, y) in enumerate(cells):
        z = UNDERSIDE_START
        for _ in range(8):  # through the robot and the object itself, up to the first other object
            hit = env.scene.px.raycast(np.array([x, y, z], dtype=np.float32), up, 1.0)
            if hit is None:
                break
            other = owner.get(hit.component.entity)
            if other is not None and other != name:
                found[index] = z + hit.distance if hit.distance > 1e-4 else 0.0
                break
            z += hit.distance + 1e-4
    return found
