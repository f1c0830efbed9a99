"""The oracle's read-only view of the scene: object geometry and pose from the simulator's true state (surface
points, footprints mapped by vertical ray casts, mass and centre of mass), what supports or contains what, the
fixtures (shelves) as boxes, and grids of the tops of everything around a point. Ray casts run on the CPU
simulator only; off it the functions that need them say so (None, or assume the simple case)."""

from __future__ import annotations

import weakref
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.geometry import Box, quat_to_matrix
from robolab_ms.policies.oracle.gripper import HAND_LENGTH, OPEN_FINGER_GAP

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

HEAVY_MASS = 0.8  # kg: an object this heavy is held near its centre of mass, like a long one
LONG_TOOL_MASS = 0.1  # kg: a long object this heavy (a hammer, a clamp, a ladle) is a tool
LONG_RATIO = 2.0  # a footprint this many times as long as wide (and longer than the open fingers' gap) is long
STANDING_TILT = 0.3  # rad: a container tilted less than this stands (its rim can be pinched from above)
LYING_TILT = 1.0  # rad: a container tilted this far lies on its side (its opening faces sideways, not up or down)
UPSIDE_DOWN_TILT = 2.2  # rad: tilted further, its opening faces down (a tip about its base cannot stand it up)
DENSE_EDGE = 0.01  # m: dense points lie on a mesh object's collision hulls' faces cut this fine
FOOTPRINT_CELL = 0.006  # m between the vertical rays that map the top of an object with few surface points ...
FOOTPRINT_MAX_POINTS = 200  # ... as many as this at most (a primitive's corners, not a mesh)
OBSTACLE_RADIUS = 0.2  # m around a grasp where the tops of other objects are looked at, on a grid ...
OBSTACLE_CELL = 0.008  # ... of this spacing
OBSTACLE_CEILING = 0.8  # m: rays looking for objects start this high
RAY_PASSES = 64  # links of the robot and the object itself a looking ray may pass ...
RAY_SKIP = 0.005  # ... stepping this far past a robot link it meets
UNDERSIDE_START = 0.001  # m above the table where the rays that find undersides start
WALL_MAX_THICKNESS = 0.03  # m: a rim thicker than this is no wall to pinch
COVER_SHARE = 0.5  # the share of an object's points under a shelf's board that makes it covered by it
HANDLE_PART_RATIO = 4.0  # a handle is a box collision part this many times as long as its thickest section ...
HANDLE_PART_THICKNESS = 0.04  # ... and no thicker than this (m), so that the open fingers close across it
SOLID_SAMPLE = 0.01  # m between the points sampled through a box collision part
BOARD_THICKNESS = 0.03  # m: an object no thicker than this, wider than the open fingers, is a board ...
BOARD_LEAN = np.radians(15.0)  # ... that leans where its long axis rises more than this
BOARD_END_SHARE = 0.2  # the share of a board's length at either end that must be as wide as it (no handle)
SEEN_MIN_POINTS = 12  # the fewest points of a ray-cast map of an object's top that are added to its own

Grid = tuple[np.ndarray, np.ndarray]  # cell centres (K, 2) and the tops of what is there (K,)


# ------------------------------------------------------------------------------------------------ objects
def world_points(env: RoboLabEnv, name: str) -> np.ndarray:
    """The object's collision surface points in the world (N, 3)."""
    return in_world(env, name, env.eval_context.entries[name].points)


def in_world(env: RoboLabEnv, name: str, local: np.ndarray) -> np.ndarray:
    """Points (N, 3) given in object `name`'s frame, in the world."""
    ctx = env.eval_context
    rotation = ctx.rotation(name)[0].cpu().numpy()
    return local @ rotation.T + ctx.position(name)[0].cpu().numpy()


_DENSE_POINTS: dict[str, np.ndarray] = {}  # per catalog object: points on its collision hulls' faces, object frame


def dense_world_points(env: RoboLabEnv, name: str) -> np.ndarray:
    """Points on the faces of a mesh object's collision hulls, no more than DENSE_EDGE apart, in the world (N, 3);
    the surface points alone for a procedural object (those are already spread over its faces)."""
    import trimesh

    entry = env.eval_context.entries[name]
    if entry.name not in _DENSE_POINTS:
        pieces = [entry.points]
        for hull in entry.hulls:
            mesh = trimesh.convex.convex_hull(hull)
            vertices, _ = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=DENSE_EDGE)
            pieces.append(np.asarray(vertices))
        _DENSE_POINTS[entry.name] = np.concatenate(pieces)
    return in_world(env, name, _DENSE_POINTS[entry.name])


def solid_points(env: RoboLabEnv, name: str) -> np.ndarray:
    """Points of object `name` in the world (N, 3): its dense surface points, and a grid SOLID_SAMPLE apart through
    each of its box collision parts (a procedural object's surface points may be only its corners)."""
    pieces = [dense_world_points(env, name)]
    actor = env.objects[name]
    for shape in actor._bodies[0].get_collision_shapes():
        half = getattr(shape, "half_size", None)
        if half is None:
            continue
        axes = [np.linspace(-h, h, max(2, int(np.ceil(2 * h / SOLID_SAMPLE)) + 1)) for h in np.asarray(half, float)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        pose = actor.pose.sp * shape.local_pose
        pieces.append(grid @ quat_to_matrix(np.asarray(pose.q)).T + np.asarray(pose.p))
    return np.concatenate(pieces)


def others_near(env: RoboLabEnv, name: str, skip: str | None) -> np.ndarray:
    """The solid points of every object but `name` and `skip`, in the world (N, 3)."""
    pieces = [solid_points(env, other) for other in env.objects if other not in (name, skip)]
    return np.concatenate(pieces) if pieces else np.zeros((0, 3))


def object_bottom(env: RoboLabEnv, name: str) -> float:
    """The height of the object's lowest point."""
    return float(world_points(env, name)[:, 2].min())


def centre(env: RoboLabEnv, name: str) -> np.ndarray:
    """The middle of the object's bounding box in the world (x, y, z)."""
    env.eval_context.refresh()
    points = world_points(env, name)
    return (points.max(axis=0) + points.min(axis=0)) / 2


def tilt(env: RoboLabEnv, name: str) -> float:
    """Angle (rad) between the object's up axis and world z."""
    env.eval_context.refresh()
    return float(np.arccos(np.clip(env.eval_context.up_axis(name)[0, 2].item(), -1.0, 1.0)))


def mass_centre(env: RoboLabEnv, name: str) -> np.ndarray:
    """The object's centre of mass in the world (x, y, z), from the simulator's body."""
    actor = env.objects[name]
    body = actor._bodies[0]
    return np.asarray((actor.pose.sp * body.cmass_local_pose).p, dtype=np.float64)


def mass(env: RoboLabEnv, name: str) -> float:
    """The object's mass in kg, from the simulator's body."""
    return float(env.objects[name]._bodies[0].mass)


def is_heavy(env: RoboLabEnv, name: str) -> bool:
    """Whether the object weighs HEAVY_MASS or more (a drill): held off its mass centre, it turns in the pads."""
    return mass(env, name) >= HEAVY_MASS


def is_long(points: np.ndarray) -> bool:
    """Whether the object of world `points` has a long footprint (a tool, a utensil): at least LONG_RATIO times as
    long as wide, and longer than the open fingers' gap."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    extents = np.ptp(xy @ vectors, axis=0)  # narrowest, then widest
    return bool(extents[1] > OPEN_FINGER_GAP and extents[1] > LONG_RATIO * extents[0])


def is_tool(env: RoboLabEnv, name: str, points: np.ndarray) -> bool:
    """Whether the object (world `points`) is a long tool (a hammer, a clamp, a ladle): long and LONG_TOOL_MASS or
    heavier."""
    return is_long(points) and mass(env, name) >= LONG_TOOL_MASS


def footprint_axes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The long and the narrow horizontal axes of the footprint of `points` (unit vectors)."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    return vectors[:, 1], vectors[:, 0]


def is_container(env: RoboLabEnv, name: str) -> bool:
    """Whether the catalog calls the object a container (a bin, a bowl, a mug)."""
    return bool(env.eval_context.entries[name].is_container)


def is_fixture(env: RoboLabEnv, name: str) -> bool:
    """Whether the object is a fixture (a shelf): it stays where it is."""
    return bool(env.eval_context.entries[name].is_fixture)


def standing_container(env: RoboLabEnv, name: str) -> bool:
    """Whether the object is a container standing on its base."""
    return env.eval_context.entries[name].is_container and tilt(env, name) < STANDING_TILT


def lying_container(env: RoboLabEnv, name: str) -> bool:
    """Whether object `name` is a container lying on its side, its opening facing sideways (CPU simulator only)."""
    if env.scene.gpu_sim_enabled or not env.eval_context.entries[name].is_container:
        return False
    return LYING_TILT < tilt(env, name) < UPSIDE_DOWN_TILT


@dataclass(frozen=True)
class Board:
    """A flat object leaning in a container: unit world axes along its length (pointing up the slope), across its
    width and through its thickness, and its length, width and thickness (m)."""

    up: np.ndarray
    across: np.ndarray
    normal: np.ndarray
    length: float
    width: float
    thickness: float


def leaning_board(env: RoboLabEnv, name: str) -> Board | None:
    """Object `name` as a `Board` where it is one (no thicker than BOARD_THICKNESS and, at both ends, wider than
    the open fingers: no hold from above fits across it) leaning in a container (`container_below`), its long axis
    rising more than BOARD_LEAN; else None."""
    local = env.eval_context.entries[name].points
    extents = np.ptp(local, axis=0)
    thin, middle, long = np.argsort(extents)
    if extents[thin] > BOARD_THICKNESS or extents[middle] <= OPEN_FINGER_GAP:
        return None
    along = local[:, long]
    for end in (along.min(), along.max()):  # as wide at both ends: flat all along (a hammer's handle is not)
        near = np.abs(along - end) <= BOARD_END_SHARE * extents[long]
        if np.ptp(local[near, middle]) <= OPEN_FINGER_GAP:
            return None
    rotation = env.eval_context.rotation(name)[0].cpu().numpy().astype(np.float64)
    up = rotation[:, long] * (1.0 if rotation[2, long] >= 0.0 else -1.0)
    if up[2] < np.sin(BOARD_LEAN) or container_below(env, name) is None:
        return None
    return Board(up, rotation[:, middle], rotation[:, thin], *(float(extents[i]) for i in (long, middle, thin)))


def container_below(env: RoboLabEnv, name: str) -> str | None:
    """The container whose footprint holds object `name`'s centre of mass, if any."""
    middle = mass_centre(env, name)
    for other in env.objects:
        if other == name or not env.eval_context.entries[other].is_container:
            continue
        points = world_points(env, other)
        if np.all(points[:, :2].min(axis=0) <= middle[:2]) and np.all(middle[:2] <= points[:, :2].max(axis=0)):
            return other
    return None


def contents_top(env: RoboLabEnv, container: str, points: np.ndarray, held: str) -> float:
    """The highest point of the objects (other than `held`) whose middle lies within the container's outline
    (`points`, its world points), or 0 where there are none."""
    low, high = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
    top = 0.0
    for other in env.objects:
        if other in (container, held):
            continue
        other_points = world_points(env, other)
        middle = (other_points[:, :2].min(axis=0) + other_points[:, :2].max(axis=0)) / 2
        if np.all(middle >= low) and np.all(middle <= high):
            top = max(top, float(other_points[:, 2].max()))
    return top


def handle_part(env: RoboLabEnv, name: str) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """The handle of object `name`, its longest thin box collision part: (its free end, the unit vector from there
    along it towards the tool's mass, its length, its radius (half the thickest cross-section)), in the world;
    None where the object has no box part long and thin enough (a mesh tool, a block)."""
    actor = env.objects[name]
    best = None
    for shape in actor._bodies[0].get_collision_shapes():
        half = getattr(shape, "half_size", None)
        if half is None:
            continue
        half = np.asarray(half, dtype=float)
        axis = int(np.argmax(half))
        thick = float(np.delete(half, axis).max())
        if half[axis] < HANDLE_PART_RATIO * thick or 2 * thick > HANDLE_PART_THICKNESS:
            continue
        if best is None or half[axis] > best[2][best[1]]:
            best = (shape, axis, half)
    if best is None:
        return None
    shape, axis, half = best
    pose = actor.pose.sp * shape.local_pose
    direction = quat_to_matrix(np.asarray(pose.q))[:, axis]
    middle = np.asarray(pose.p, dtype=float)
    if float((mass_centre(env, name) - middle) @ direction) < 0:  # from the free end towards the tool's mass
        direction = -direction
    length = 2 * float(half[axis])
    return middle - direction * half[axis], direction, length, float(np.delete(half, axis).max())


# ------------------------------------------------------------------------------------------------ ray casts
def ray_hit(env: RoboLabEnv, name: str, start: np.ndarray, direction_z: float) -> float | None:
    """Height where a vertical ray from `start` (up for +1, down for -1) first meets object `name`, if it does (on
    the CPU simulator only)."""
    if env.scene.gpu_sim_enabled:
        raise OracleFailure("rim grasps need ray casts, which the oracle does only on the CPU simulator")
    direction = np.array([0.0, 0.0, direction_z], dtype=np.float32)
    hit = env.scene.px.raycast(start.astype(np.float32), direction, 1.0)
    if hit is None or hit.component.entity not in env.objects[name]._objs:
        return None
    return float(start[2] + direction_z * hit.distance)


def hits(env: RoboLabEnv, name: str, xy: np.ndarray, top: float) -> bool:
    """Whether a ray cast straight down at `xy`, from just above the object's `top`, meets the object first (on the
    CPU simulator; elsewhere assumed)."""
    if env.scene.gpu_sim_enabled:
        return True
    return ray_hit(env, name, np.array([xy[0], xy[1], top + 0.01]), -1.0) is not None


def footprint_points(env: RoboLabEnv, name: str, points: np.ndarray) -> np.ndarray | None:
    """The object seen from above: for every cell of a FOOTPRINT_CELL grid over its footprint where a vertical
    ray meets it first, a point at its top there and one at its bottom (as if its sides were vertical); None off
    the CPU simulator or where the object has enough surface points of its own (a mesh)."""
    if env.scene.gpu_sim_enabled or len(points) > FOOTPRINT_MAX_POINTS:
        return None
    low, high = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
    bottom, top = float(points[:, 2].min()), float(points[:, 2].max())
    xs = np.arange(low[0] + FOOTPRINT_CELL / 2, high[0], FOOTPRINT_CELL)
    ys = np.arange(low[1] + FOOTPRINT_CELL / 2, high[1], FOOTPRINT_CELL)
    found = []
    for x in xs:
        for y in ys:
            z = ray_hit(env, name, np.array([x, y, top + 0.01]), -1.0)
            if z is not None:
                found.append((x, y, z))
                found.append((x, y, bottom))
    return np.array(found) if found else None


def seen_points(env: RoboLabEnv, name: str) -> np.ndarray:
    """The object's points, with its top mapped from above where it has few surface points (a primitive's
    corners) and the map has at least SEEN_MIN_POINTS points."""
    points = world_points(env, name)
    seen = footprint_points(env, name, points)
    return points if seen is None or len(seen) < SEEN_MIN_POINTS else np.concatenate([points, seen])


def scene_state(env: RoboLabEnv) -> bytes:
    """The poses of every body of the scene (objects, the robot's links, fixtures) as bytes: equal while nothing
    in the scene has moved, so that what rays meet is the same."""
    px = env.scene.px
    poses = []
    for component in (
        *px.get_rigid_dynamic_components(),
        *px.get_articulation_link_components(),
        *px.get_rigid_static_components(),
    ):
        pose = component.get_entity_pose()
        poses.append(np.concatenate([pose.p, pose.q]))
    return np.asarray(poses, dtype=np.float64).tobytes()


class RayMaps:
    """Ray-cast grids of the scene last asked about, kept for as long as nothing in it moves: each map is looked
    up by what it was cast for and by `scene_state` (the poses of every body), so a map is cast again as soon as
    any body has moved. A few scene states are kept at once (the planner may move the robot and back). With `keep`
    False every map is cast anew (the baseline of benchmarks/validation_cost.py)."""

    STATES = 4  # scene states whose maps are kept

    def __init__(self) -> None:
        self.keep = True
        self.scene: weakref.ref | None = None
        self.maps: OrderedDict[bytes, dict[tuple, object]] = OrderedDict()

    def of(self, env: RoboLabEnv) -> dict[tuple, object]:
        """The maps cast in `env`'s scene as it is now (an empty dict to fill where it has moved)."""
        if self.scene is None or self.scene() is not env.scene:
            self.scene, self.maps = weakref.ref(env.scene), OrderedDict()
        state = scene_state(env)
        if state in self.maps:
            self.maps.move_to_end(state)
        else:
            self.maps[state] = {}
            while len(self.maps) > self.STATES:
                self.maps.popitem(last=False)
        return self.maps[state]

    def clear(self) -> None:
        """Forget every map."""
        self.scene, self.maps = None, OrderedDict()


RAY_MAPS = RayMaps()


def surface_grid(
    env: RoboLabEnv, name: str, middle: np.ndarray, radius: float, cell: float
) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
    """The first thing that vertical rays meet, passing through the robot and object `name`, on a grid of `cell`
    spacing around `middle`: cell centres (K, 2), heights (K,; the table's, or 0, where no object is) and the
    names of the objects hit (None: the table or nothing). Cast once while nothing in the scene moves (`RAY_MAPS`)."""
    middle = np.asarray(middle)
    key = ("surface", name, middle.dtype.str, middle.tobytes(), type(radius), radius, type(cell), cell)
    if not RAY_MAPS.keep:
        return cast_surface_grid(env, name, middle, radius, cell)
    maps = RAY_MAPS.of(env)
    if key not in maps:
        maps[key] = cast_surface_grid(env, name, middle, radius, cell)
    cells, heights, names = maps[key]
    return cells.copy(), heights.copy(), list(names)


def cast_surface_grid(
    env: RoboLabEnv, name: str, middle: np.ndarray, radius: float, cell: float
) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
    """`surface_grid`, cast anew."""
    owner = {entity: other for other, actor in env.objects.items() for entity in actor._objs}
    robot = {link.entity for link in env.agent.robot._objs[0].links}
    steps = np.arange(-radius, radius + 1e-9, cell)
    cells = np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2) + middle
    heights, names = np.zeros(len(cells)), [None] * len(cells)
    down = np.array([0.0, 0.0, -1.0], dtype=np.float32)
    start = np.zeros(3, dtype=np.float32)
    raycast = env.scene.px.raycast
    for index, (x, y) in enumerate(cells.tolist()):
        z = OBSTACLE_CEILING
        start[0], start[1] = x, y
        for _ in range(RAY_PASSES):  # through the robot and the object itself, down to the first other object
            start[2] = z
            hit = raycast(start, down, z + 0.05)
            if hit is None:
                break
            entity, z = hit.component.entity, z - hit.distance
            other = owner.get(entity)
            if other is not None and other != name:
                heights[index], names[index] = z, other
                break
            if other is None and entity not in robot:  # the table or the floor
                heights[index] = z
                break
            z -= RAY_SKIP if entity in robot else 1e-4  # out of a robot link (from inside it the ray meets it again)
    return cells, heights, names


def obstacle_heights(env: RoboLabEnv, name: str, middle: np.ndarray) -> Grid | None:
    """The top heights of everything but object `name`, the robot and the table, on a grid of vertical rays around
    `middle` (cell centres (K, 2), heights (K,), -inf where nothing is); None off the CPU simulator."""
    if env.scene.gpu_sim_enabled:
        return None
    cells, heights, names = surface_grid(env, name, middle, OBSTACLE_RADIUS, OBSTACLE_CELL)
    return cells, np.where([other is None for other in names], -np.inf, heights)


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


def wall_along(
    env: RoboLabEnv, name: str, middle: np.ndarray, outward: np.ndarray, radius: float, top: float
) -> tuple[float, float] | None:
    """Inner and outer distance (m) from `middle` of the container's wall at its rim along `outward`, from vertical
    ray casts 2 mm apart; None where the rim there is not a thin wall."""
    at_rim = []
    for distance in np.arange(0.0, radius + 0.01, 0.002):
        start = np.array([*(middle + outward * distance), top + 0.02])
        hit = ray_hit(env, name, start, -1.0)
        if hit is not None and hit > top - 0.01:
            at_rim.append(distance)
    if not at_rim:
        return None
    inner, outer = min(at_rim), max(at_rim)
    if outer - inner > WALL_MAX_THICKNESS or inner < 0.01:
        return None
    return inner, outer


# ------------------------------------------------------------------------------------------------ fixtures
def fixture_boxes(env: RoboLabEnv) -> list[Box]:
    """The solid pieces of every fixture (shelves) as boxes in the world: rotation (3, 3), centre (3,), half
    extents (3,). A procedural piece's own box (its bounding box where it is no box); a mesh piece's bounding box."""
    env.eval_context.refresh()
    boxes = []
    for name in env.objects:
        entry = env.eval_context.entries[name]
        if not entry.is_fixture:
            continue
        rotation = env.eval_context.rotation(name)[0].cpu().numpy().astype(np.float64)
        position = env.eval_context.position(name)[0].cpu().numpy().astype(np.float64)
        if entry.parts:
            for part in entry.parts:
                if part.shape == "box":
                    local, half = quat_to_matrix(part.rotation), np.asarray(part.size, dtype=np.float64)
                else:
                    local, half = np.eye(3), part.half_extent()
                boxes.append((rotation @ local, rotation @ np.asarray(part.position) + position, half))
        else:
            for hull in entry.hulls:
                low, high = hull.min(axis=0), hull.max(axis=0)
                boxes.append((rotation, rotation @ ((low + high) / 2) + position, (high - low) / 2))
    return boxes


def covering_boxes(points: np.ndarray, boxes: list[Box]) -> list[Box]:
    """The fixture boxes over the object of world `points` (over at least COVER_SHARE of its points, seen from
    above: an object beside a shelf that reaches a little under it is not covered), less than the hand's length
    above its top."""
    high = points.max(axis=0)
    found = []
    for rotation, middle, half in boxes:
        extent = np.abs(rotation) @ half
        box_low = middle - extent
        local = (points - middle) @ rotation  # in the box's frame: under it where both horizontal axes are inside
        horizontal = [axis for axis in range(3) if abs(rotation[2, axis]) < 0.5]
        under = np.all(np.abs(local[:, horizontal]) <= half[horizontal], axis=1)
        over = under.mean() >= COVER_SHARE
        if over and high[2] <= box_low[2] < high[2] + HAND_LENGTH:
            found.append((rotation, middle, half))
    return found


def covered(env: RoboLabEnv, name: str, boxes: list[Box] | None = None) -> bool:
    """Whether a fixture's piece (a shelf's upper level) lies over object `name` lower than a hand coming from
    above would need: within the object's footprint and less than the hand's length above its top."""
    boxes = fixture_boxes(env) if boxes is None else boxes
    return bool(covering_boxes(world_points(env, name), boxes))


def open_side_depths(points: np.ndarray, boxes: list[Box]) -> list[tuple[float, np.ndarray]]:
    """The sides of the shelf level that covers the object of world `points`, by which a hand may come in to it:
    (depth, face) per side of the covering board that faces the robot, where face is the side's outward normal
    (unit x, y) and depth how far (m) the object's nearest point lies in from that side; the nearest side first."""
    rotation, middle, half = covering_boxes(points, boxes)[0]
    towards_robot = -points[:, :2].mean(axis=0) / np.linalg.norm(points[:, :2].mean(axis=0))
    sides = []
    for axis in range(2):
        normal = rotation[:2, axis] / np.linalg.norm(rotation[:2, axis])
        for sign in (1.0, -1.0):
            face = sign * normal
            if face @ towards_robot > 0.0:
                depth = float(middle[:2] @ face + half[axis] - (points[:, :2] @ face).max())
                sides.append((depth, face))
    return sorted(sides, key=lambda item: item[0])


def open_sides(points: np.ndarray, boxes: list[Box]) -> list[np.ndarray]:
    """Horizontal directions (unit x, y) out of the shelf whose level covers the object of world `points`: the
    outward normals of the covering board's sides that face the robot, the side nearest the object first."""
    return [face for _, face in open_side_depths(points, boxes)]
