"""Where the oracle sets several objects down on one small flat top (a closed box's lid).

`free_place` puts each object at the free spot nearest the middle, testing axis-aligned boxes round the object. On
a top barely larger than two objects' footprints that fails twice over: the first object, set in the middle,
leaves no room for the next; and an object lying at a slant fills an axis-aligned box as large as the whole top.
What counts as on such a top is the object's middle (the column above it), and what keeps it there is its middle
resting well inside the edge. So the spots are chosen together: the object's true outline (the convex hull of its
points and the open fingers round it), its middle at least SUPPORT_INSET inside the flat top, clear of what is
already there, and, where more objects are still to go onto the same top, leaving a spot of that kind for the next
one (held as its own grasp would hold it). Of those pairs, the one whose farther middle is nearest the top's middle,
and among nearly equal ones the first object farthest from the robot (the arm reaching the next spot sweeps past
what stands nearer it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np
from scipy.spatial import Delaunay

from robolab_ms.catalog.procedural import quat_to_matrix

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv
    from robolab_ms.policies.oracle import Job, OraclePolicy

SUPPORT_INSET = 0.03  # m: every point this near an object's middle lies over the flat top (it rests, not tips)
SHARE_MARGIN = 0.025  # m kept between an object's outline (with its open fingers) and another's
SHARED_AREA = 0.8  # the objects' footprints (x, y boxes) cover at least this share of the top: it is small for them
CARRY_CLEARANCE = 0.06  # m between the held object's bottom, where it is carried in, and the top of what is there
SHARE_TRIES = 12  # pairs of spots tried for reach, best first
_OCTAGON = np.array([[np.cos(a), np.sin(a)] for a in np.linspace(0.0, 2 * np.pi, 8, endpoint=False)])


def crowded_top(env: RoboLabEnv, onto: str, names: list[str]) -> bool:
    """Whether `onto` is a flat top (not a container) on which the footprints (x, y boxes as they lie now) of the
    objects `names` together cover at least SHARED_AREA of its own: too small to set them anywhere."""
    from robolab_ms.policies.oracle import _world_points

    if env.scene.gpu_sim_enabled or len(names) < 2 or env.eval_context.entries[onto].is_container:
        return False
    env.eval_context.refresh()

    def area(name: str) -> float:
        points = _world_points(env, name)[:, :2]
        return float(np.prod(points.max(axis=0) - points.min(axis=0)))

    return sum(area(name) for name in names) >= SHARED_AREA * area(onto)


def _outline(held: np.ndarray, grasp: np.ndarray, margin: float) -> np.ndarray:
    """The corners (x, y relative to the TCP) of the outline of an object (its points `held`, relative to the TCP)
    and the open fingers of `grasp` round it, widened by `margin`."""
    from robolab_ms.policies.oracle import FINGER_HALF_WIDTH, OPEN_FINGER_REACH

    rotation = quat_to_matrix(grasp[3:])
    closing, across = rotation[:2, 1], rotation[:2, 0]
    closing, across = closing / max(np.linalg.norm(closing), 1e-9), across / max(np.linalg.norm(across), 1e-9)
    fingers = np.array(
        [s * OPEN_FINGER_REACH * closing + t * FINGER_HALF_WIDTH * across for s in (-1, 1) for t in (-1, 1)]
    )
    points = np.concatenate([held, fingers])
    return (points[:, None, :] + margin * _OCTAGON[None]).reshape(-1, 2)


def _covers(outline: np.ndarray, offsets: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(N, K): whether the outline (corners relative to the TCP) with the TCP at each of `offsets` (N, 2) covers
    each of `cells` (K, 2)."""
    hull = Delaunay(outline)
    local = cells[None, :, :] - offsets[:, None, :]
    return (hull.find_simplex(local.reshape(-1, 2)) >= 0).reshape(len(offsets), len(cells))


def _spots(cells: np.ndarray, flat: np.ndarray, middle_offset: np.ndarray) -> np.ndarray:
    """TCP positions (N, 2) that put an object's middle (`middle_offset` from the TCP) over a cell of `flat` with
    every cell within SUPPORT_INSET of it flat too."""
    from robolab_ms.policies.oracle import PLACE_CELL

    inside = []
    for cell in cells[flat]:
        near = np.linalg.norm(cells - cell, axis=1) <= SUPPORT_INSET
        if flat[near].all() and near.sum() >= np.pi * (SUPPORT_INSET / PLACE_CELL) ** 2 * 0.8:
            inside.append(cell)
    return np.array(inside).reshape(-1, 2) - middle_offset


def shared_place(
    env: RoboLabEnv,
    name: str,
    onto: str,
    grasp: np.ndarray,
    held_bottom: float,
    reachable: Callable[[np.ndarray, np.ndarray], bool],
    after: list[str],
) -> tuple[np.ndarray, np.ndarray] | None:
    """A release pose of the TCP, and the pose above it, that set `name` (held by `grasp`, not turned) down on the
    flat top of `onto` with its middle well inside the edge and its outline clear of what is there, leaving such a
    spot for the first of `after` (objects still to go onto `onto`); None where there is no such pair of spots or
    none is reached."""
    from robolab_ms.policies.oracle import (
        PLACE_CELL,
        PLACE_FLATNESS,
        RELEASE_CLEARANCE,
        _over_place,
        _surface_grid,
        _world_points,
        grasp_pose,
    )

    env.eval_context.refresh()
    target = _world_points(env, onto)
    low, high = target[:, :2].min(axis=0), target[:, :2].max(axis=0)
    middle = (low + high) / 2
    radius = float(np.max(high - middle)) + 0.12  # objects may reach past the edge
    cells, heights, names = _surface_grid(env, name, middle, radius, PLACE_CELL)
    on_target = np.array([other == onto for other in names])
    if not on_target.any():
        return None
    level = heights[on_target].min()
    flat = on_target & (heights <= level + PLACE_FLATNESS)
    blocked = np.array([other is not None and other != onto for other in names]) & (heights > level - 0.01)

    held = _world_points(env, name)[:, :2] - grasp[:2]
    body_offset = (held.min(axis=0) + held.max(axis=0)) / 2
    spots = _spots(cells, flat, body_offset)
    if not len(spots):
        return None
    covered = _covers(_outline(held, grasp, SHARE_MARGIN), spots, cells)
    clear = ~(covered & blocked[None]).any(axis=1)
    spots, covered = spots[clear], covered[clear]
    if not len(spots):
        return None
    distance = np.linalg.norm(spots + body_offset - middle, axis=1)
    score = distance
    if after:  # the next object's spots that each of these leaves free
        nxt = after[0]
        next_grasp = grasp_pose(env, nxt, failed=[])
        next_held = _world_points(env, nxt)[:, :2] - next_grasp[:2]
        next_offset = (next_held.min(axis=0) + next_held.max(axis=0)) / 2
        next_spots = _spots(cells, flat, next_offset)
        if not len(next_spots):
            return None
        next_covered = _covers(_outline(next_held, next_grasp, 0.0), next_spots, cells)
        next_clear = ~(next_covered & blocked[None]).any(axis=1)
        next_spots, next_covered = next_spots[next_clear], next_covered[next_clear]
        if not len(next_spots):
            return None
        clash = covered.astype(np.float32) @ next_covered.T.astype(np.float32) > 0  # (this spot, next spot)
        next_distance = np.linalg.norm(next_spots + next_offset - middle, axis=1)
        best_next = np.where(clash, np.inf, next_distance[None, :]).min(axis=1)
        score = np.maximum(distance, best_next)
    tallest = float(heights[blocked].max(initial=level))
    # within a centimetre of the best, farthest from the robot first: the arm then reaches past nothing standing
    order = np.lexsort((-np.linalg.norm(spots + body_offset, axis=1), np.round(score / PLACE_CELL)))
    order = order[np.isfinite(score[order])]
    for index in order[:SHARE_TRIES]:
        tcp = spots[index]
        z = float(heights[covered[index] & on_target].max(initial=level)) + RELEASE_CLEARANCE + held_bottom
        pose = np.concatenate([[tcp[0], tcp[1], z], grasp[3:]])
        for over in _over_place(env, pose, held_bottom, name, onto):
            over = over.copy()  # carried in above what already stands there (a tall carton), not through it
            over[2] = max(over[2], tallest + CARRY_CLEARANCE + held_bottom)
            if reachable(over, pose):
                return pose, over
    return None


def shared_spot(
    policy: OraclePolicy,
    job: Job,
    grasp: np.ndarray,
    held_bottom: float,
    reachable: Callable[[np.ndarray, np.ndarray], bool],
) -> tuple[np.ndarray, np.ndarray] | None:
    """`shared_place` for the job's object where the task's jobs set several objects onto one crowded flat top
    (see `crowded_top`), leaving room for those still queued; None elsewhere, or where it finds no spot."""
    from robolab_ms.policies.oracle import jobs_for

    env = policy.env
    if job.onto is None or env.scene.gpu_sim_enabled:
        return None
    sharing = [other.obj for other in jobs_for(env) if other.onto == job.onto and not other.centred]
    if job.obj not in sharing or not crowded_top(env, job.onto, sharing):
        return None
    after = [
        other.obj for other in policy.jobs if other.onto == job.onto and not other.centred and other.obj != job.obj
    ]
    return shared_place(env, job.obj, job.onto, grasp, held_bottom, reachable, after)
