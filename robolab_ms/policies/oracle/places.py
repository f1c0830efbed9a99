"""Where a held object is set down. Every relation is answered by a free-spot search over a ray-cast map of the
target's surface, with the held object's footprint (and, where they fit, the open fingers) kept clear of what is
already there:
- in or on an object (`free_place`): a flat part of a bin's floor or a plate, nearest its middle, or the farthest
  spot the arm reaches over a bin's rim where the middle is out of reach (`backed_off` a little from the edge of
  the reach), with the hand turned about the vertical where it must be (`turned_place`); a tool with a heavy end
  too long for a pot's floor goes in head first (`head_first_place`); several objects onto one small flat top
  choose their spots together (`shared_place`); the fallback is over the target's middle (`place_pose`);
- on the table (`free_spot`): beside a reference (`spot_beside`: left of, right of, in front of, behind, next to),
  near a point, or anywhere in the safe area, clear of everything else; off a shelf level, outside the shelf on its
  open side (`shelf_exit_spot`).
`Reachable` tests (from the motion layer) say whether the arm lowers the object straight from a pose over a spot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np
from scipy.spatial import Delaunay

from robolab_ms.policies.oracle.clearance import APPROACH_HEIGHT, above
from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.geometry import matrix_to_quaternion, quat_to_matrix, rotation_about
from robolab_ms.policies.oracle.grasps import grasp_pose, heavy_end
from robolab_ms.policies.oracle.gripper import FINGER_HALF_WIDTH, OPEN_FINGER_REACH
from robolab_ms.policies.oracle.world import (
    Board,
    centre,
    container_below,
    contents_top,
    covering_boxes,
    fixture_boxes,
    is_tool,
    open_sides,
    surface_grid,
    world_points,
)

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

Reachable = Callable[[np.ndarray, np.ndarray], bool]  # (pose over the place, release pose) -> reached and lowered
Spot = tuple[np.ndarray, np.ndarray]  # (release pose of the TCP, the pose over it that it is lowered from)

RELEASE_CLEARANCE = 0.03  # m between the held object's bottom and the place surface when the gripper opens
SIDE_OFFSET = 0.15  # m from a reference's centre to where an object is put beside it (left of, behind, ...)
DIRECTIONS = {"left_of": (0.0, 1.0), "right_of": (0.0, -1.0), "in_front_of": (-1.0, 0.0), "behind": (1.0, 0.0)}
NEXT_TO = DIRECTIONS["left_of"]  # `next_to` puts the object on the left
TABLE_SAFE_X, TABLE_SAFE_Y = (0.30, 0.75), (-0.40, 0.40)  # where the oracle may put things down (robot frame, m)
TABLE_GRID = (19, 33)  # spots tried across the safe area along x and y
SPOT_MARGIN = 0.03  # m of table kept clear around an object the oracle puts down
STAND_GAP = 0.03  # m between a container's wall and a board stood on its end beside it, at least ...
STAND_OUT = 0.15  # ... and at most this much more
STAND_ALONG = 0.12  # m a board's standing spot may move along the wall either way
STAND_STEP = 0.01  # m between the standing spots tried
STAND_MARGIN = 0.005  # m kept between a standing board's end and anything else (it stands there only a moment)
STAND_TURNS = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0)  # degrees a standing board may be turned about the vertical
PLACE_CELL = 0.01  # m between the rays that map a container's floor or a plate when choosing where to set down
PLACE_FLATNESS = 0.02  # m a place spot may rise above the lowest point of the container or plate
PLACE_MARGIN = 0.015  # m kept between an object set down in a container or on a plate and what is already there
PLACE_TURNS = (0, 15, -15, 30, -30, 45, -45, 60, -60, 75, -75, 90)  # degrees the hand may turn to fit a place
TABLE_TURNS = (0, 180, 90, -90, 135, -135, 45, -45)  # degrees a held object may turn about the vertical over a spot
PLACE_MIDDLE = 0.04  # m: a long object too big for a floor has at least this much around its middle over it
PLACE_REACH_TRIES = 12  # free spots tried for reach where the middle is out of reach ...
PLACE_REACH_MARGIN = 0.04  # ... and the one chosen this much nearer the robot than the farthest reached, if free
ROOM_MARGIN = 0.015  # m between the object where it is moved in to and a second one of its size beside it
HEAD_FIRST_MARGIN = 0.012  # m kept between a heavy end and the pot's wall (or what already lies in it) on release
HEAD_FIRST_TURNS = 24  # directions of the handle tried around the pot
HEAD_FIRST_CELL = 0.01  # m between the rays that map the pot and its surroundings
HEAD_FIRST_SAMPLES = 400  # points of the held tool at most that decide what lies under it
SAMPLE_BATCH = 64  # points (or cells) compared with a whole map at once
SUPPORT_INSET = 0.03  # m: every point this near an object's middle lies over the flat top (it rests, not tips)
SUPPORT_SHARE = 0.8  # the share of the disc of SUPPORT_INSET that must be mapped flat cells
SHARE_MARGIN = 0.025  # m kept between an object's outline (with its open fingers) and another's
SHARED_AREA = 0.8  # the objects' footprints (x, y boxes) cover at least this share of the top: it is small for them
SHARE_REACH = 0.12  # m past a shared top's edge that the map reaches (objects may reach past the edge)
SHARE_BLOCK_DEPTH = 0.01  # m below the top's level that what is mapped there still blocks a spot
CARRY_CLEARANCE = 0.06  # m between the held object's bottom, where it is carried in, and the top of what is there
SHARE_TRIES = 12  # pairs of spots tried for reach, best first
_OCTAGON = np.array([[np.cos(a), np.sin(a)] for a in np.linspace(0.0, 2 * np.pi, 8, endpoint=False)])


# ------------------------------------------------------------------------------------------------ on the table
def spot_beside(env: RoboLabEnv, reference: str, relation: str) -> tuple[float, float]:
    """Where (x, y) the middle of an object's footprint goes to stand `relation` (a key of DIRECTIONS, or
    `next_to`) the object `reference`: SIDE_OFFSET from its centre."""
    dx, dy = DIRECTIONS.get(relation, NEXT_TO)
    middle = centre(env, reference)
    return (middle[0] + dx * SIDE_OFFSET, middle[1] + dy * SIDE_OFFSET)


def in_safe_area(xy: np.ndarray) -> bool:
    """Whether table point `xy` lies in the area where the oracle may put things down."""
    return bool(TABLE_SAFE_X[0] <= xy[0] <= TABLE_SAFE_X[1] and TABLE_SAFE_Y[0] <= xy[1] <= TABLE_SAFE_Y[1])


def footprints(env: RoboLabEnv, skip: list[str]) -> list[np.ndarray]:
    """The footprint [x_min, y_min, x_max, y_max] of every object of the scene but those in `skip`."""
    boxes = []
    for other in env.objects:
        if other not in skip:
            points = world_points(env, other)[:, :2]
            boxes.append(np.concatenate([points.min(axis=0), points.max(axis=0)]))
    return boxes


def clear_spots(spots: np.ndarray, half: np.ndarray, boxes: list[np.ndarray], margin: float) -> np.ndarray:
    """Which of the table points `spots` (N, 2) a footprint of half extents `half` (x, y) centred there keeps at
    least `margin` from every footprint in `boxes`."""
    ok = np.ones(len(spots), dtype=bool)
    for box in boxes:
        middle, other_half = (box[:2] + box[2:]) / 2, (box[2:] - box[:2]) / 2
        gaps = np.abs(spots - middle) - half - other_half  # per axis; apart when either gap is wide enough
        ok &= gaps.max(axis=1) >= margin
    return ok


def free_spot(
    env: RoboLabEnv, name: str, avoid: list[str], taken: list[np.ndarray], near: np.ndarray | None = None
) -> np.ndarray:
    """A footprint [x_min, y_min, x_max, y_max] on the table where `name`, moved without turning, can be put down:
    SPOT_MARGIN clear of every other object's footprint (except those in `avoid`, which are on the move) and of the
    footprints in `taken`; of those, the one nearest the point `near` (x, y), else the middle of the safe area."""
    own = world_points(env, name)[:, :2]
    half = (own.max(axis=0) - own.min(axis=0)) / 2
    xs, ys = np.meshgrid(np.linspace(*TABLE_SAFE_X, TABLE_GRID[0]), np.linspace(*TABLE_SAFE_Y, TABLE_GRID[1]))
    spots = np.stack([xs.ravel(), ys.ravel()], axis=1)
    ok = clear_spots(spots, half, footprints(env, [name, *avoid]) + list(taken), SPOT_MARGIN)
    if not ok.any():
        raise OracleFailure(f"no free spot on the table for '{name}' {SPOT_MARGIN:.2f} m clear of everything else")
    middle = np.array([np.mean(TABLE_SAFE_X), np.mean(TABLE_SAFE_Y)]) if near is None else np.asarray(near)
    spot = spots[ok][np.linalg.norm(spots[ok] - middle, axis=1).argmin()]
    return np.concatenate([spot - half, spot + half])


@dataclass(frozen=True)
class StandingSpot:
    """Where a board stands on its end beside its container: the footprint [x_min, y_min, x_max, y_max], the turn
    (rad, about the vertical) from how it leans to how it stands there, and the horizontal unit direction it is
    laid down in, away from the container."""

    box: np.ndarray
    turn: float
    lay: np.ndarray


def standing_spot(
    env: RoboLabEnv, name: str, board: Board, taken: list[np.ndarray], at: np.ndarray | None = None
) -> StandingSpot:
    """A spot on the table, outside the container that board `name` leans in, on the side its raised end leans out
    over (or at `at`), where the board stood on its end keeps STAND_MARGIN from every other object and from the
    footprints in `taken`, and from where it is laid down flat away from the container, its middle landing in the
    safe area. The least turned first, then nearest the wall and the board's middle."""
    container = container_below(env, name)
    box = world_points(env, container)[:, :2]
    out = np.array([board.up[0], board.up[1]]) / np.linalg.norm(board.up[:2])
    along = np.array([-out[1], out[0]])
    middle = centre(env, name)[:2]
    if at is None:
        wall = float((box @ out).max())
        start = middle + out * (wall - middle @ out + board.thickness / 2 + STAND_GAP)
        outs = np.arange(0.0, STAND_OUT + 1e-9, STAND_STEP)
        alongs = np.arange(-STAND_ALONG, STAND_ALONG + 1e-9, STAND_STEP)
        offsets = np.array([(o, a) for o in outs for a in alongs])
        offsets = offsets[np.argsort(np.hypot(offsets[:, 0], offsets[:, 1]), kind="stable")]
        spots = start + offsets[:, :1] * out + offsets[:, 1:] * along
    else:
        spots = np.asarray(at, dtype=np.float64)[None]
    boxes = footprints(env, [name]) + list(taken)
    safe = np.array([in_safe_area(spot) for spot in spots])
    container_middle = (box.max(axis=0) + box.min(axis=0)) / 2
    axis = np.cross(board.up, [0.0, 0.0, 1.0])
    stood = rotation_about(axis / np.linalg.norm(axis), float(np.arccos(np.clip(board.up[2], -1.0, 1.0))))
    flat_across, flat_normal = (stood @ board.across)[:2], (stood @ board.normal)[:2]  # as it stands, unturned
    for degrees in STAND_TURNS:
        turn = np.radians(degrees)
        rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        across, normal = rotation @ flat_across, rotation @ flat_normal
        across /= max(float(np.linalg.norm(across)), 1e-9)
        normal /= max(float(np.linalg.norm(normal)), 1e-9)
        half = np.abs(across) * board.width / 2 + np.abs(normal) * board.thickness / 2
        ok = safe & clear_spots(spots, half, boxes, STAND_MARGIN)
        for spot in spots[ok]:
            away = spot - container_middle
            for lay in sorted((normal, -normal), key=lambda direction: -float(direction @ away)):
                if float(lay @ away) > 0.0 and in_safe_area(spot + lay * board.length / 2):
                    return StandingSpot(np.concatenate([spot - half, spot + half]), float(turn), lay)
    raise OracleFailure(f"no spot beside '{container}' where '{name}' can be stood on its end and laid down")


def shelf_exit_spot(env: RoboLabEnv, name: str) -> np.ndarray:
    """Where (x, y) on the table an object taken off a covered shelf level is best put down: outside the shelf on
    the open side it is pulled out of, and to the side of the level's middle that it stands on, past the level's
    edge, so that it blocks neither its own way out nor that of anything else on the level."""
    points = world_points(env, name)
    boxes = fixture_boxes(env)
    rotation, board, half = covering_boxes(points, boxes)[0]
    out = open_sides(points, boxes)[0]
    middle = (points.max(axis=0) + points.min(axis=0)) / 2
    size = points[:, :2].max(axis=0) - points[:, :2].min(axis=0)
    along = np.array([-out[1], out[0]])  # the open side's direction, horizontal
    extent = np.abs(rotation[:2]) @ half  # the board's half extents in the world's x and y ...
    out_reach, side_reach = abs(extent @ np.abs(out)), abs(extent @ np.abs(along))  # ... across and along the side
    out_room = float((board[:2] - middle[:2]) @ out) + out_reach + np.abs(size) @ np.abs(out) / 2 + SPOT_MARGIN
    sign = 1.0 if float((middle[:2] - board[:2]) @ along) >= 0.0 else -1.0
    side_room = float((board[:2] - middle[:2]) @ along) + sign * (side_reach + np.abs(size) @ np.abs(along) / 2)
    return middle[:2] + out * out_room + along * side_room


# ------------------------------------------------------------------------------------------------ in or on objects
@dataclass(frozen=True)
class TargetSurface:
    """What vertical rays (passing through the robot and the held object) meet on and around `target`, the object
    a held object goes onto: the middle of the target's footprint, cell centres (K, 2), the heights (K,) and names
    of what is hit (None: the table or nothing), which cells are the target's, its lowest level among them, and
    its flat cells (no more than PLACE_FLATNESS above that level: a bin's floor, a plate)."""

    target: str
    middle: np.ndarray
    cells: np.ndarray
    heights: np.ndarray
    names: list[str | None]
    on_target: np.ndarray
    level: float
    flat: np.ndarray

    @property
    def others(self) -> np.ndarray:
        """Which cells hold another object (already in or on the target, or beside it)."""
        return np.array([other is not None and other != self.target for other in self.names])


def map_target(
    env: RoboLabEnv,
    name: str,
    onto: str,
    beyond: float = 0.0,
    cell: float = PLACE_CELL,
    radius: float | None = None,
) -> TargetSurface | None:
    """The map of `onto`'s surface for setting `name` down on it: a grid of `cell` spacing around the middle of its
    footprint, as far as its footprint reaches and `beyond` (or `radius` from the middle); None where no ray meets
    `onto` (off the CPU simulator there are no rays: callers check first)."""
    target = world_points(env, onto)
    low, high = target[:, :2].min(axis=0), target[:, :2].max(axis=0)
    middle = (low + high) / 2
    if radius is None:
        radius = float(np.max(high - middle)) + beyond
    cells, heights, names = surface_grid(env, name, middle, radius, cell)
    on_target = np.array([other == onto for other in names])
    if not on_target.any():
        return None
    level = heights[on_target].min()
    flat = on_target & (heights <= level + PLACE_FLATNESS)
    return TargetSurface(onto, middle, cells, heights, names, on_target, level, flat)


class GridWindows:
    """Axis-aligned windows over the cells (K, 2) of a map: which cells each of many TCP positions covers with a
    box relative to it, answered axis by axis on the cells' distinct x and y values (a map's cells form a grid),
    the same tests `cells - tcp >= low` and `cells - tcp <= high` made cell by cell."""

    def __init__(self, cells: np.ndarray) -> None:
        self.xs, self.column = np.unique(cells[:, 0], return_inverse=True)
        self.ys, self.row = np.unique(cells[:, 1], return_inverse=True)

    def within(self, tcps: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per TCP (N, 2), which distinct x values and which y values ((N, X), (N, Y)) lie between `low` and
        `high` (x, y) relative to it."""
        along = []
        for axis, values in ((0, self.xs), (1, self.ys)):
            local = values[None, :] - tcps[:, axis : axis + 1]
            along.append((local >= low[axis : axis + 1]) & (local <= high[axis : axis + 1]))
        return along[0], along[1]

    def around(self, tcps: np.ndarray, offset: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
        """As `within`, the values no more than `reach` from `offset` (x, y) relative to each TCP."""
        along = []
        for axis, values in ((0, self.xs), (1, self.ys)):
            local = values[None, :] - tcps[:, axis : axis + 1]
            along.append(np.abs(local - offset[axis : axis + 1]) <= reach)
        return along[0], along[1]

    def grid(self, marked: np.ndarray) -> np.ndarray:
        """The count of `marked` cells (K,) at each pair of distinct x and y values (X, Y)."""
        flat_index = self.column * len(self.ys) + self.row
        counts = np.bincount(flat_index, weights=marked.astype(np.float64), minlength=len(self.xs) * len(self.ys))
        return counts.reshape(len(self.xs), len(self.ys))

    def holds(self, along_x: np.ndarray, along_y: np.ndarray, counts: np.ndarray) -> np.ndarray:
        """(N,): whether each window (`along_x`, `along_y` from `within`) holds a cell counted in `counts`."""
        return ((along_x.astype(np.float64) @ counts) * along_y).sum(axis=1) > 0

    def cover(self, along_x: np.ndarray, along_y: np.ndarray) -> np.ndarray:
        """(N, K): which cells each window covers."""
        return along_x[:, self.column] & along_y[:, self.row]


def place_pose(
    env: RoboLabEnv,
    name: str,
    onto: str | None,
    at: tuple[float, float] | None,
    grasp: np.ndarray,
    held_bottom: float,
    held_offset: np.ndarray,
) -> Spot:
    """Where the TCP goes to release object `name`, and where above it the object is carried first (see
    `over_place`): centred over `onto` with the object's bottom just above its top (a container's rim must be
    cleared on the way down, and what already fills it: a keyboard over the rim; `free_place` finds a better spot
    where it can), or just above the table with the middle of the object's footprint (`held_offset` from the TCP)
    at `at`."""
    if onto is not None:
        points = world_points(env, onto)
        x, y = (points[:, :2].max(axis=0) + points[:, :2].min(axis=0)) / 2
        top = points[:, 2].max()
        if env.eval_context.entries[onto].is_container:
            top = max(top, contents_top(env, onto, points, name))
    else:
        (x, y), top = np.asarray(at) + held_offset, 0.0
    place = np.concatenate([[x, y, top + RELEASE_CLEARANCE + held_bottom], grasp[3:]])
    return place, over_place(env, place, held_bottom, name, onto)[0]


def turned_table_place(
    env: RoboLabEnv,
    name: str,
    at: tuple[float, float],
    grasp: np.ndarray,
    held_bottom: float,
    held_offset: np.ndarray,
    reachable: Reachable,
) -> Spot | None:
    """`place_pose` on the table at `at`, with the held object (and the hand with it) turned about the vertical
    through the middle of its footprint by TABLE_TURNS in turn: a hand that leans out of a shelf towards the robot
    cannot set an object down near the robot's base as it holds it, but turned half round it leans away from the
    robot. The first release pose and the pose above it that `reachable`, in TABLE_TURNS' order (as the object lies,
    then half round, then by quarter and eighth turns); None where no turn is reached."""
    for turn in TABLE_TURNS:
        spin = rotation_about(np.array([0.0, 0.0, 1.0]), np.radians(turn))
        turned_grasp = np.concatenate([grasp[:3], matrix_to_quaternion(spin @ quat_to_matrix(grasp[3:]))])
        offset = spin[:2, :2] @ np.asarray(held_offset)[:2]
        place, over = place_pose(env, name, None, at, turned_grasp, held_bottom, offset)
        if reachable(over, place):
            return place, over
    return None


def over_place(env: RoboLabEnv, place: np.ndarray, held_bottom: float, held: str, onto: str | None) -> list[np.ndarray]:
    """Where the held object may be carried to before it is lowered straight to `place`, best first: as high as
    above a release just over the top of `onto` (the way in to a low release inside a bin is then as high as the
    way to one over its rim), then only APPROACH_HEIGHT above `place` (see `clearance.above`) where that is lower."""
    low = above(env, place, APPROACH_HEIGHT, hanging=held_bottom, held=held)
    if onto is None:
        return [low]
    high = low.copy()
    high[2] = max(low[2], world_points(env, onto)[:, 2].max() + RELEASE_CLEARANCE + held_bottom + APPROACH_HEIGHT)
    if high[2] <= low[2] + 1e-3:
        return [low]
    # where that is out of reach: the held object's bottom just over the top of `onto` (a tall crate's walls, which
    # `above` may not see where the crate has only its corners as points), before the lowest way in
    rim = low.copy()
    rim[2] = high[2] - APPROACH_HEIGHT + RELEASE_CLEARANCE
    return [high, rim, low] if rim[2] > low[2] + 1e-3 else [high, low]


def free_place(
    env: RoboLabEnv,
    name: str,
    onto: str,
    grasp: np.ndarray,
    held_bottom: float,
    reachable: Reachable,
    first_pass: int = 0,
    turns: tuple[float, ...] = (),
) -> Spot | None:
    """A release pose of the TCP, and the pose above it that it is lowered from, that set `name` (held by `grasp`,
    not turned) down on a flat part of `onto` (a bin's floor, a plate) clear of what already lies there: the
    object's footprint and the open fingers over `onto` no more than PLACE_FLATNESS above its lowest point, nothing
    else within PLACE_MARGIN of the object (where no spot has that room: the object alone over the flat part,
    touching nothing else). Of those spots, the one nearest the middle of `onto` if `reachable(over, place)` (the
    arm reaches the pose over it and moves straight down from there), else about the farthest from the robot that
    it reaches. The object's bottom is released RELEASE_CLEARANCE above the highest point under it. None where no
    such spot exists (a bowl's curved inside) or off the CPU simulator."""
    if env.scene.gpu_sim_enabled:
        return None
    env.eval_context.refresh()
    held_points = world_points(env, name)[:, :2] - grasp[:2]  # the held object relative to the TCP
    surface = map_target(env, name, onto, beyond=PLACE_CELL)
    if surface is None:
        return None
    middle, cells, heights, on_target, flat = (
        surface.middle,
        surface.cells,
        surface.heights,
        surface.on_target,
        surface.flat,
    )
    others = surface.others
    is_container = env.eval_context.entries[onto].is_container
    windows = GridWindows(cells)
    off_floor, off_floor_on_target, taken = (
        windows.grid(~flat),
        windows.grid(~flat & on_target),
        windows.grid(others),
    )
    free = []  # release poses, middlemost first
    # the object and the open fingers with room around; where nothing has that room, the object alone; the hand
    # turned about the vertical as little as needed (a long tool fits a bin only along it)
    # last, for a long object that fits no floor (its middle is what counts as in): its middle over the floor and the
    # rest over whatever is there (a rim), released above all of it
    tool = is_tool(env, name, held_points)
    passes = ((True, True), (False, True), (False, False)) if tool else ((True, True), (None, True), (False, True))
    for pass_index, (with_fingers, whole) in enumerate(passes[first_pass:], start=first_pass):  # noqa: B007 (read after the loop)
        for turn in turns or (PLACE_TURNS if tool else PLACE_TURNS[:1]):  # only a long tool turns (a spoon fits
            # as held), unless `turns` are given (the hand turned by these degrees about the vertical)
            spin = rotation_about(np.array([0.0, 0.0, 1.0]), np.radians(turn))
            held = held_points @ spin[:2, :2].T
            quaternion = matrix_to_quaternion(spin @ quat_to_matrix(grasp[3:]))
            body_low, body_high = held.min(axis=0), held.max(axis=0)
            if with_fingers:
                closing = (spin @ quat_to_matrix(grasp[3:]))[:2, 1]
                fingers = np.abs(closing) * OPEN_FINGER_REACH + np.abs(closing[::-1]) * FINGER_HALF_WIDTH
                foot_low, foot_high = np.minimum(body_low, -fingers), np.maximum(body_high, fingers)
                margin = PLACE_MARGIN
            else:  # None: the object with room around, the open fingers perhaps touching a neighbour
                foot_low, foot_high, margin = body_low, body_high, PLACE_MARGIN if with_fingers is None else 0.0
            centre_offset = (body_low + body_high) / 2
            candidates = cells[flat] - centre_offset  # TCP positions putting the object's middle over a flat cell
            order = np.argsort(np.linalg.norm(candidates + centre_offset - middle, axis=1), kind="stable")
            tcps = candidates[order]
            under_x, under_y = windows.within(tcps, foot_low, foot_high)
            if whole:
                middle_x, middle_y = under_x, under_y
            else:
                middle_x, middle_y = windows.around(tcps, centre_offset, PLACE_MIDDLE)
            # on a wall, a rim or the edge (a plate may have the table under the fingers)
            on_edge = windows.holds(middle_x, middle_y, off_floor if is_container else off_floor_on_target)
            crowded = windows.holds(*windows.within(tcps, body_low - margin, body_high + margin), taken)
            accepted = np.flatnonzero(~on_edge & ~crowded)
            under = windows.cover(under_x[accepted], under_y[accepted])  # (accepted spots, cells)
            tops = np.where(under, heights, -np.inf).max(axis=1, initial=-np.inf)
            for tcp, top, covers in zip(tcps[accepted], tops, under):
                if not covers.any():
                    top = heights[covers].max()  # nothing under the object: fails as the maximum of no heights
                z = top + RELEASE_CLEARANCE + held_bottom
                free.append(np.concatenate([[tcp[0], tcp[1], z], quaternion]))
            if free and whole:
                break
        if free:
            break
    if free and not whole:  # the turn and spot that let it down lowest (most of it over the floor)
        free.sort(key=lambda pose: round(float(pose[2]), 2))
    if not free:
        return None

    clearing = [True, False]  # first only ways in over the rim of `onto`, then the lowest way in as well

    def reached(pose: np.ndarray) -> Spot | None:
        overs = over_place(env, pose, held_bottom, name, onto)
        for over in overs[:-1] if clearing[0] and len(overs) > 1 else overs:
            if reachable(over, pose):
                return pose, over
        return None

    found = reached(free[0])
    if found is not None:
        return found
    found = reached_over_rim(free, reached)  # a spot nearer the robot that the held object reaches over the rim
    if found is not None:  # a little nearer still, where that leaves room for another object of its size
        return backed_off(free, found, reached, held_points, grasp)
    clearing[0] = False
    found = reached(free[0])
    if found is not None:
        return found
    # the middle is out of reach (a large bin): the free spot farthest from the robot that it reaches, so that the
    # nearer ones are left for what comes next (reach falls off with the distance: a binary search)
    farthest_first = sorted(free, key=lambda pose: -float(np.linalg.norm(pose[:2])))
    low, high = 0, len(farthest_first) - 1
    for _ in range(PLACE_REACH_TRIES):
        if low > high:
            break
        index = (low + high) // 2
        attempt = reached(farthest_first[index])
        if attempt is not None:
            found, high = attempt, index - 1
        else:
            low = index + 1
    if found is not None:  # at the very edge of the reach the arm takes odd postures: a little nearer if free
        edge = float(np.linalg.norm(found[0][:2]))
        for pose in farthest_first:
            if float(np.linalg.norm(pose[:2])) <= edge - PLACE_REACH_MARGIN:
                return reached(pose) or found
    if found is None and pass_index + 1 < len(passes):  # none of these in reach: less room (the fingers may touch)
        return free_place(env, name, onto, grasp, held_bottom, reachable, first_pass=pass_index + 1, turns=turns)
    return found


def reached_over_rim(free: list[np.ndarray], reached: Callable[[np.ndarray], Spot | None]) -> Spot | None:
    """Of the release poses `free`, the one farthest from the robot that `reached` finds a way in to, tried from
    the nearest to the robot outwards in PLACE_REACH_TRIES steps (a binary search: reach falls off with distance);
    None where none is reached."""
    nearest_first = sorted(free, key=lambda pose: float(np.linalg.norm(pose[:2])))
    if reached(nearest_first[0]) is None:
        return None
    found, low, high = reached(nearest_first[0]), 1, len(nearest_first) - 1
    for _ in range(PLACE_REACH_TRIES):
        if low > high:
            break
        index = (low + high) // 2
        attempt = reached(nearest_first[index])
        if attempt is not None:
            found, low = attempt, index + 1
        else:
            high = index - 1
    return found


def backed_off(
    free: list[np.ndarray],
    found: Spot,
    reached: Callable[[np.ndarray], Spot | None],
    held: np.ndarray,
    grasp: np.ndarray,
) -> Spot:
    """The release poses `found` (the free spot farthest from the robot that the arm reaches, at the edge of its
    reach, where it takes odd postures and sweeps through a bin's wall on its way back) moved in to the farthest
    free spot of `free` at least PLACE_REACH_MARGIN nearer the robot that `reached` finds a way to, if an object of
    the held one's size still fits beside it there, on a free spot at most as far as `found` (two long tools in one
    bin need the far spot); else `found`. `held`: the held object's points (x, y) relative to the TCP of `grasp`."""
    edge = float(np.linalg.norm(found[0][:2]))
    nearer = [pose for pose in free if float(np.linalg.norm(pose[:2])) <= edge - PLACE_REACH_MARGIN]
    if not nearer:
        return found
    pose = max(nearer, key=lambda pose: float(np.linalg.norm(pose[:2])))
    low, high = footprint_at(pose, held, grasp)
    for other in free:  # within the reach found (the spots beyond it are out of reach)
        if float(np.linalg.norm(other[:2])) > edge:
            continue
        other_low, other_high = footprint_at(other, held, grasp)
        if np.any(other_low > high + ROOM_MARGIN) or np.any(low > other_high + ROOM_MARGIN):
            return reached(pose) or found
    return found


def footprint_at(pose: np.ndarray, held: np.ndarray, grasp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box (low (x, y), high (x, y)) of the held object's points `held` (relative to the TCP of
    `grasp`) with the TCP at release pose `pose` (turned from `grasp` about the vertical)."""
    turn = quat_to_matrix(pose[3:]) @ quat_to_matrix(grasp[3:]).T
    points = held @ turn[:2, :2].T + pose[:2]
    return points.min(axis=0), points.max(axis=0)


def turned_place(
    env: RoboLabEnv, name: str, onto: str, grasp: np.ndarray, held_bottom: float, reachable: Reachable
) -> Spot | None:
    """`free_place` with the hand turned about the vertical, by PLACE_TURNS in turn (the least turn first), for a
    held object that no free spot of `onto` takes with the hand as it grasped: near the edge of the arm's reach the
    wrist's turn decides whether a pose is reached at all. The first release pose and the pose above it that is
    reached; None where no turn has one."""
    for turn in PLACE_TURNS[1:]:
        spot = free_place(env, name, onto, grasp, held_bottom, reachable, turns=(turn,))
        if spot is not None:
            return spot
    return None


def head_first_place(
    env: RoboLabEnv, name: str, onto: str, grasp: np.ndarray, held_bottom: float, reachable: Reachable
) -> Spot | None:
    """For a tool with a heavy wide end (see `grasps.heavy_end`) too long for the floor of container `onto`: a
    release pose of the TCP (holding it by `grasp`), and the pose above it that it is lowered from, with the heavy
    end over the floor next to the wall (HEAD_FIRST_MARGIN clear of the wall and of what already lies there), the
    tool's middle over the floor and the handle out over the far rim, the tool's bottom RELEASE_CLEARANCE above
    everything under it: the heavy end drops in and the handle comes to lean on the rim. Of the directions of the
    handle (the hand turned about the vertical) the first that `reachable(over, place)`. None for other objects or
    containers, where the tool fits the floor, off the CPU simulator, or where no direction is reached."""
    if env.scene.gpu_sim_enabled or not env.eval_context.entries[onto].is_container:
        return None
    found = heavy_end(env, name)
    if found is None:
        return None
    centre_of_mass, head_radius, towards = found
    env.eval_context.refresh()
    held = world_points(env, name)
    length = float(np.ptp(held[:, :2] @ towards))
    surface = map_target(env, name, onto, cell=HEAD_FIRST_CELL, radius=length + HEAD_FIRST_CELL)
    if surface is None:
        return None
    middle, cells, heights, floor = surface.middle, surface.cells, surface.heights, surface.flat
    floor_radius = float(np.linalg.norm(cells[floor] - middle, axis=1).max()) if floor.any() else 0.0
    if length <= 2 * floor_radius:  # it lies flat on the floor: free_place sets it down
        return None
    blocked = ~floor  # the wall, the rim, the outside and whatever already lies in the pot
    # the held tool relative to the TCP: its points, its mass centre and its middle
    offsets = held[:, :2] - grasp[:2]
    mass_offset = centre_of_mass[:2] - grasp[:2]
    middle_offset = (held[:, :2].max(axis=0) + held[:, :2].min(axis=0)) / 2 - grasp[:2]
    start_angle = float(np.arctan2(towards[1], towards[0]))
    angles = [start_angle + turn for turn in np.radians(np.arange(HEAD_FIRST_TURNS) * 360.0 / HEAD_FIRST_TURNS)]
    angles.sort(key=lambda angle: abs((angle - start_angle + np.pi) % (2 * np.pi) - np.pi))  # least turned first
    for angle in angles:
        turn = angle - start_angle
        spin = rotation_about(np.array([0.0, 0.0, 1.0]), turn)
        direction = np.array([np.cos(angle), np.sin(angle)])  # from the heavy end towards the handle
        for inset in np.arange(floor_radius - head_radius - HEAD_FIRST_MARGIN, -1e-9, -HEAD_FIRST_CELL):
            head_at = middle - direction * inset
            near_head = np.linalg.norm(cells - head_at, axis=1) < head_radius + HEAD_FIRST_MARGIN
            if blocked[near_head].any():
                continue
            tcp = head_at - spin[:2, :2] @ mass_offset
            tool_middle = tcp + spin[:2, :2] @ middle_offset
            if not floor[np.linalg.norm(cells - tool_middle, axis=1) < HEAD_FIRST_CELL].any():
                break  # the middle would not be over the floor: the next direction
            footprint = offsets @ spin[:2, :2].T + tcp
            under = np.zeros(len(cells), dtype=bool)
            samples = footprint[:: max(1, len(footprint) // HEAD_FIRST_SAMPLES)]
            for start in range(0, len(samples), SAMPLE_BATCH):
                points = samples[start : start + SAMPLE_BATCH]
                under |= (np.abs(cells[None, :, :] - points[:, None, :]).max(axis=2) <= HEAD_FIRST_CELL).any(axis=0)
            z = float(heights[under].max()) + RELEASE_CLEARANCE + held_bottom
            quaternion = matrix_to_quaternion(spin @ quat_to_matrix(grasp[3:]))
            place = np.concatenate([[tcp[0], tcp[1], z], quaternion])
            for over in over_place(env, place, held_bottom, name, onto):
                if reachable(over, place):
                    return place, over
            break  # this direction is not reached: the next
    return None


# ------------------------------------------------------------------------------------------------ shared tops
def crowded_top(env: RoboLabEnv, onto: str, names: list[str]) -> bool:
    """Whether `onto` is a flat top (not a container) on which the footprints (x, y boxes as they lie now) of the
    objects `names` together cover at least SHARED_AREA of its own: too small to set them anywhere."""
    if env.scene.gpu_sim_enabled or len(names) < 2 or env.eval_context.entries[onto].is_container:
        return False
    env.eval_context.refresh()

    def area(name: str) -> float:
        points = world_points(env, name)[:, :2]
        return float(np.prod(points.max(axis=0) - points.min(axis=0)))

    return sum(area(name) for name in names) >= SHARED_AREA * area(onto)


def outline(held: np.ndarray, grasp: np.ndarray, margin: float) -> np.ndarray:
    """The corners (x, y relative to the TCP) of the outline of an object (its points `held`, relative to the TCP)
    and the open fingers of `grasp` round it, widened by `margin`."""
    rotation = quat_to_matrix(grasp[3:])
    closing, across = rotation[:2, 1], rotation[:2, 0]
    closing, across = closing / max(np.linalg.norm(closing), 1e-9), across / max(np.linalg.norm(across), 1e-9)
    fingers = np.array(
        [s * OPEN_FINGER_REACH * closing + t * FINGER_HALF_WIDTH * across for s in (-1, 1) for t in (-1, 1)]
    )
    points = np.concatenate([held, fingers])
    return (points[:, None, :] + margin * _OCTAGON[None]).reshape(-1, 2)


def outline_covers(corners: np.ndarray, offsets: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(N, K): whether the outline (`corners` relative to the TCP) with the TCP at each of `offsets` (N, 2) covers
    each of `cells` (K, 2)."""
    hull = Delaunay(corners)
    local = cells[None, :, :] - offsets[:, None, :]
    return (hull.find_simplex(local.reshape(-1, 2)) >= 0).reshape(len(offsets), len(cells))


def supported_spots(cells: np.ndarray, flat: np.ndarray, middle_offset: np.ndarray) -> np.ndarray:
    """TCP positions (N, 2) that put an object's middle (`middle_offset` from the TCP) over a cell of `flat` with
    every cell within SUPPORT_INSET of it flat too."""
    inside = []
    centres = cells[flat]
    for start in range(0, len(centres), SAMPLE_BATCH):
        chunk = centres[start : start + SAMPLE_BATCH]
        near = np.linalg.norm(cells[None, :, :] - chunk[:, None, :], axis=2) <= SUPPORT_INSET
        enough = near.sum(axis=1) >= np.pi * (SUPPORT_INSET / PLACE_CELL) ** 2 * SUPPORT_SHARE
        inside.extend(chunk[~(near & ~flat).any(axis=1) & enough])
    return np.array(inside).reshape(-1, 2) - middle_offset


def shared_place(
    env: RoboLabEnv,
    name: str,
    onto: str,
    grasp: np.ndarray,
    held_bottom: float,
    reachable: Reachable,
    after: list[str],
) -> Spot | None:
    """A release pose of the TCP, and the pose above it, that set `name` (held by `grasp`, not turned) down on the
    flat top of `onto` with its middle well inside the edge (SUPPORT_INSET: what counts as on it is the column
    above its middle, and what keeps it there is its middle resting well inside the edge) and its true outline
    (with the open fingers) clear of what is there, leaving such a spot for the first of `after` (objects still to
    go onto `onto`, held as its own grasp would hold it). Of those pairs, the one whose farther middle is nearest
    the top's middle, and among nearly equal ones the first object farthest from the robot (the arm reaching the
    next spot sweeps past what stands nearer it); carried in CARRY_CLEARANCE above the tallest thing there. None
    where there is no such pair of spots or none is reached."""
    env.eval_context.refresh()
    surface = map_target(env, name, onto, beyond=SHARE_REACH)
    if surface is None:
        return None
    middle, cells, heights, level = surface.middle, surface.cells, surface.heights, surface.level
    on_target, flat = surface.on_target, surface.flat
    blocked = surface.others & (heights > level - SHARE_BLOCK_DEPTH)

    held = world_points(env, name)[:, :2] - grasp[:2]
    body_offset = (held.min(axis=0) + held.max(axis=0)) / 2
    spots = supported_spots(cells, flat, body_offset)
    if not len(spots):
        return None
    covered = outline_covers(outline(held, grasp, SHARE_MARGIN), spots, cells)
    clear = ~(covered & blocked[None]).any(axis=1)
    spots, covered = spots[clear], covered[clear]
    if not len(spots):
        return None
    distance = np.linalg.norm(spots + body_offset - middle, axis=1)
    score = distance
    if after:  # the next object's spots that each of these leaves free
        following = after[0]
        next_grasp = grasp_pose(env, following, failed=[])
        next_held = world_points(env, following)[:, :2] - next_grasp[:2]
        next_offset = (next_held.min(axis=0) + next_held.max(axis=0)) / 2
        next_spots = supported_spots(cells, flat, next_offset)
        if not len(next_spots):
            return None
        next_covered = outline_covers(outline(next_held, next_grasp, 0.0), next_spots, cells)
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
        for over in over_place(env, pose, held_bottom, name, onto):
            over = over.copy()  # carried in above what already stands there (a tall carton), not through it
            over[2] = max(over[2], tallest + CARRY_CLEARANCE + held_bottom)
            if reachable(over, pose):
                return pose, over
    return None
