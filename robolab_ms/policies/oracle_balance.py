"""The oracle's balance grasp and head-first place, for a long tool whose weight sits in a wide end (a ladle: a
deep bowl on a thin handle).

Held at its mass centre such a tool is held by the bowl, which the open fingers barely go round: it turns out of
the pads as it is lifted. It is held instead by the handle just beside the bowl, where the pads close on a narrow
bar a few centimetres from the mass centre. Such a tool is longer than a pot is wide, so it cannot be set down
flat on the floor: it is let go over the pot with its heavy end over the floor near one wall and the handle
pointing across the middle and out over the far rim, so that the bowl drops in and the handle comes to lean on
the rim, the tool's middle over the pot.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

BALANCE_WIDE = 0.06  # m: a tool this wide (or wider) across at its mass centre is held by a narrower part beside it ...
BALANCE_NARROW = 0.035  # ... at most this wide ...
BALANCE_REACH = 0.08  # ... at most this far (m) from the mass centre along the tool
BALANCE_STEP = 0.005  # m between the places along the tool tried for that narrow part
BALANCE_GAP = 0.01  # m kept between the pads' sides and the wide part
HEAD_FIRST_MARGIN = 0.012  # m kept between the heavy end and the pot's wall (or what already lies in it) on release
HEAD_FIRST_TURNS = 24  # directions of the handle tried around the pot
HEAD_FIRST_CELL = 0.01  # m between the rays that map the pot and its surroundings


def _axes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The long and the narrow horizontal axes of a footprint (unit vectors)."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    return vectors[:, 1], vectors[:, 0]


def _seen(env: RoboLabEnv, name: str) -> np.ndarray:
    """The object's points, with its top mapped from above where it has few surface points (a primitive's
    corners)."""
    from robolab_ms.policies import oracle

    points = oracle._world_points(env, name)
    seen = oracle._footprint_points(env, name, points)
    return points if seen is None or len(seen) < oracle.MIN_SLAB_POINTS else np.concatenate([points, seen])


def heavy_end(env: RoboLabEnv, name: str) -> tuple[np.ndarray, float, np.ndarray] | None:
    """For a long tool whose mass centre lies in (or at the edge of) a part at least BALANCE_WIDE across (a
    ladle's bowl): the mass centre (x, y, z), the half width of that part and the horizontal unit vector from the
    mass centre towards the tool's middle (along the handle); None for any other object."""
    from robolab_ms.policies import oracle

    points = oracle._world_points(env, name)
    if not oracle._tool(env, name, points):
        return None
    points = _seen(env, name)
    mass_centre = oracle._mass_centre(env, name)
    long, narrow = _axes(points)
    along = (points[:, :2] - mass_centre[:2]) @ long
    at = np.abs(along) < 2 * oracle.FINGER_HALF_WIDTH  # where the pads of a grasp at the mass centre reach
    if at.sum() < 2:
        return None
    width = float(np.ptp(points[at, :2] @ narrow))
    if width < BALANCE_WIDE:
        return None
    middle = (points.max(axis=0) + points.min(axis=0)) / 2
    towards = long if float((middle[:2] - mass_centre[:2]) @ long) >= 0.0 else -long
    return mass_centre, width / 2, towards


def balance_grasp(env: RoboLabEnv, name: str, failed: list[np.ndarray] = ()) -> np.ndarray | None:
    """A top-down grasp [x, y, z, qw, qx, qy, qz] of a tool with a heavy wide end (see `heavy_end`) by its narrow
    part nearest the mass centre, the fingers closing across it at the height of its middle (the closed pads'
    lower ends clear of the table), the nearest one not near a grasp in `failed`; None for other objects, or where
    no narrow part within BALANCE_REACH is clear of the neighbours and of `failed`."""
    from robolab_ms.policies import oracle

    if env.scene.gpu_sim_enabled:
        return None
    found = heavy_end(env, name)
    if found is None:
        return None
    mass_centre, _, towards = found
    points = _seen(env, name)
    across = np.array([-towards[1], towards[0]])
    along = (points[:, :2] - mass_centre[:2]) @ towards
    bottom = float(points[:, 2].min())
    heights = oracle._obstacle_heights(env, name, mass_centre[:2])
    offset = (points[:, :2] - mass_centre[:2]) @ across
    wide = np.abs(offset - np.median(offset)) > BALANCE_NARROW / 2
    wide_end = float(along[wide].max(initial=0.0))  # where the wide part ends towards the handle
    half = oracle.FINGER_HALF_WIDTH + BALANCE_GAP  # the wide part stays this far from the middle of the pads
    for distance in np.arange(max(wide_end + half, BALANCE_STEP), BALANCE_REACH + 1e-9, BALANCE_STEP):
        slab = points[np.abs(along - distance) < oracle.FINGER_HALF_WIDTH]
        if len(slab) < 2 or float(np.ptp(slab[:, :2] @ across)) > BALANCE_NARROW:
            continue
        width = float(np.ptp(slab[:, :2] @ across))
        middle_across = (float((slab[:, :2] @ across).max()) + float((slab[:, :2] @ across).min())) / 2
        xy = mass_centre[:2] + towards * distance
        xy = xy + across * (middle_across - float(xy @ across))
        top = float(slab[:, 2].max())
        under = oracle._ray_hit(env, name, np.array([xy[0], xy[1], bottom + 0.001]), 1.0)  # a handle held up
        underside = bottom if under is None or under >= top else under
        drop = float(np.interp(width, oracle.PAD_DROP_WIDTHS, oracle.PAD_DROP))
        z = max((top + underside) / 2, bottom + drop + oracle.FINGERTIP_CLEARANCE)
        fingers, body = oracle._hand_clash(heights, xy, across, z)
        if fingers > oracle.FINGER_CLASH_TOLERANCE or body > oracle.BODY_CLASH_TOLERANCE:
            continue
        if failed and oracle._near_failed(xy, across, list(failed)):
            continue  # further along the handle (one near the balance point may be out of reach)
        return np.concatenate([[xy[0], xy[1], z], oracle._down_quaternion(across)])
    return None


def head_first_place(
    env: RoboLabEnv,
    name: str,
    onto: str,
    grasp: np.ndarray,
    held_bottom: float,
    reachable: Callable[[np.ndarray, np.ndarray], bool],
) -> tuple[np.ndarray, np.ndarray] | None:
    """For a tool with a heavy wide end (see `heavy_end`) too long for the floor of container `onto`: a release
    pose of the TCP (holding it by `grasp`), and the pose above it that it is lowered from, with the heavy end over
    the floor next to the wall (HEAD_FIRST_MARGIN clear of the wall and of what already lies there), the tool's
    middle over the floor and the handle out over the far rim, the tool's bottom RELEASE_CLEARANCE above everything
    under it; of the directions of the handle (the hand turned about the vertical) the first that
    `reachable(over, place)`. None for other objects or containers, where the tool fits the floor, off the CPU
    simulator, or where no direction is reached."""
    from robolab_ms.policies import oracle

    if env.scene.gpu_sim_enabled or not env.eval_context.entries[onto].is_container:
        return None
    found = heavy_end(env, name)
    if found is None:
        return None
    mass_centre, head_radius, towards = found
    env.eval_context.refresh()
    held = oracle._world_points(env, name)
    length = float(np.ptp(held[:, :2] @ towards))
    target = oracle._world_points(env, onto)
    centre = (target[:, :2].max(axis=0) + target[:, :2].min(axis=0)) / 2
    cells, heights, names = oracle._surface_grid(env, name, centre, length + HEAD_FIRST_CELL, HEAD_FIRST_CELL)
    on_target = np.array([other == onto for other in names])
    if not on_target.any():
        return None
    level = heights[on_target].min()
    floor = on_target & (heights <= level + oracle.PLACE_FLATNESS)
    floor_radius = float(np.linalg.norm(cells[floor] - centre, axis=1).max()) if floor.any() else 0.0
    if length <= 2 * floor_radius:  # it lies flat on the floor: free_place sets it down
        return None
    blocked = ~floor  # the wall, the rim, the outside and whatever already lies in the pot
    # the held tool relative to the TCP: its points, its mass centre and its middle
    offsets = held[:, :2] - grasp[:2]
    mass_offset = mass_centre[:2] - grasp[:2]
    middle_offset = (held[:, :2].max(axis=0) + held[:, :2].min(axis=0)) / 2 - grasp[:2]
    start_angle = float(np.arctan2(towards[1], towards[0]))
    angles = [start_angle + turn for turn in np.radians(np.arange(HEAD_FIRST_TURNS) * 360.0 / HEAD_FIRST_TURNS)]
    angles.sort(key=lambda angle: abs((angle - start_angle + np.pi) % (2 * np.pi) - np.pi))  # least turned first
    for angle in angles:
        turn = angle - start_angle
        spin = oracle._rotation_about(np.array([0.0, 0.0, 1.0]), turn)
        direction = np.array([np.cos(angle), np.sin(angle)])  # from the heavy end towards the handle
        for inset in np.arange(floor_radius - head_radius - HEAD_FIRST_MARGIN, -1e-9, -HEAD_FIRST_CELL):
            head_at = centre - direction * inset
            near_head = np.linalg.norm(cells - head_at, axis=1) < head_radius + HEAD_FIRST_MARGIN
            if blocked[near_head].any():
                continue
            tcp = head_at - spin[:2, :2] @ mass_offset
            middle = tcp + spin[:2, :2] @ middle_offset
            if not floor[np.linalg.norm(cells - middle, axis=1) < HEAD_FIRST_CELL].any():
                break  # the middle would not be over the floor: the next direction
            footprint = offsets @ spin[:2, :2].T + tcp
            under = np.zeros(len(cells), dtype=bool)
            for point in footprint[:: max(1, len(footprint) // 400)]:
                under |= np.abs(cells - point).max(axis=1) <= HEAD_FIRST_CELL
            z = float(heights[under].max()) + oracle.RELEASE_CLEARANCE + held_bottom
            quaternion = oracle._matrix_to_quaternion(spin @ oracle.quat_to_matrix(grasp[3:]))
            place = np.concatenate([[tcp[0], tcp[1], z], quaternion])
            for over in oracle._over_place(env, place, held_bottom, name, onto):
                if reachable(over, place):
                    return place, over
            break  # this direction is not reached: the next
    return None
