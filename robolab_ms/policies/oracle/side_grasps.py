"""Grasps with the hand not pointing straight down, for what a top-down hand cannot reach or hold:
- the rim of a container lying on its side (`rim_grasp`, turned about the vertical and raised at the wrist by
  `turned_rim_grasps` where the straight-in hand meets a neighbour), for tipping it up about its base;
- an object on a shelf level under another (`front_grasps`): the hand leans in from the open side;
- a long tool lying in a container with its handle out over the wall (`side_grips`): the hand comes in level
  across the handle, the fingers closing in the vertical plane through it;
- a board leaning in a container (`board_end_grasp`): the hand points down its slope at its raised end, the fingers
  closing across its thickness.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.geometry import (
    Box,
    inside_boxes,
    matrix_to_quaternion,
    quat_to_matrix,
    raised,
    rotation_about,
    shifted,
    turned,
)
from robolab_ms.policies.oracle.grasps import GRASP_DEPTH, WALL_GRASP_DEPTH
from robolab_ms.policies.oracle.gripper import (
    HAND_FIXTURE_MARGIN,
    MAX_GRASP_WIDTH,
    PAD_BELOW_TCP,
    PAD_HALF_WIDTH,
    hand_clear,
    hand_points,
    pad_drop,
)
from robolab_ms.policies.oracle.world import (
    STANDING_TILT,
    Board,
    container_below,
    fixture_boxes,
    handle_part,
    in_world,
    open_sides,
    others_near,
    ray_hit,
    tilt,
    wall_along,
    world_points,
)

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

# rim grasps of lying containers
RIM_DEPTH = 0.02  # m the TCP reaches into a lying container's opening for a rim grasp
RIM_YAWS = (0.0, 20.0, -20.0, 35.0, -35.0, 50.0, -50.0)  # degrees a rim grasp's hand turns about the vertical ...
RIM_PITCHES = (0.0, 12.0, 24.0, 36.0)  # ... and degrees its wrist rises (the pads tilt off the wall: a firm hold
# needs little)
NEIGHBOUR_MARGIN = 0.01  # m kept between the hand at a grasp and the bounding box of any other object
# front grasps under a shelf level
FRONT_TILTS = (15.0, 20.0, 25.0, 30.0, 40.0, 55.0, 70.0)  # degrees from vertical the hand leans out, least first
FRONT_TURNS = (0.0, 20.0, -20.0, 40.0, -40.0)  # degrees the leaning direction turns away from the robot's direction
FRONT_INSET = 0.03  # m inside a long object's end nearest the open side where a leaning hand grasps it
FRONT_APPROACH = 0.08  # m the hand comes in along its own axis to a front grasp
FRONT_PAD_CLEARANCE = 0.001  # m between a leaning hand's lowest pad corner and the level under a thin object
FRONT_PAD_BITE = 0.003  # m the pads' lower edge reaches below a thin part's top, their lowest corner at most ...
FRONT_PAD_DIG = 0.005  # ... this far below the part's bottom (it rests a little above the level; the pad gives)
FRONT_LIFT = 0.015  # m an object is lifted off its level before it is pulled out
FRONT_ENOUGH = 4  # front grasps found at one lean that end the search
RIM_CLEARANCE = 0.01  # m between the open pads' lowest corner and a wall's rim where the hand comes down onto it
PULL_STEP = 0.02  # m between the poses tried when moving a hand out of a shelf ...
PULL_MAX = 0.4  # ... at most this far
# side holds of a handle
PACKED_GAP = 0.01  # m: a neighbour this close beside the handle (any way along it) blocks that side
OVERHANG_MIN = 0.06  # m of the handle (along it) that must reach out of the container's footprint
WALL_MARGIN = 0.03  # m (along the handle) the grip stays out from the container's wall ...
END_MARGIN = 0.025  # ... and in from the handle's end
SIDE_REACH = 0.09  # m beside the handle (level, across it) the hand needs free of other objects ...
SIDE_HEIGHT = 0.04  # ... within this far above or below the handle's axis ...
SIDE_ALONG = 0.04  # ... and this far either way along it
GRIP_PAST = -0.004  # m the TCP goes past the handle's axis (short: the fingertips, 1 cm on, stay off a neighbour)
STANDING_HANDLE = 0.7  # a handle whose axis has a vertical share above this stands up: no side hold
HANDLE_SAMPLES = 60  # points along a handle's axis that tell how far it reaches out of its container


# ------------------------------------------------------------------------------------------------ rims
def rim_grasp(env: RoboLabEnv, name: str, up: np.ndarray) -> np.ndarray:
    """A grasp [x, y, z, qw, qx, qy, qz] of a container lying on its side (its opening facing `up`, roughly
    horizontal): the hand points into the opening and the fingers close vertically on the top of the rim's wall,
    one finger inside the container and one above it."""
    env.eval_context.refresh()
    points = world_points(env, name)
    reach = points @ up
    mouth = reach.max()
    near_mouth = points[reach > mouth - RIM_DEPTH - 0.01]
    top = near_mouth[near_mouth[:, 2].argmax()]  # the top of the wall beside the opening
    at = top + up * (mouth - RIM_DEPTH - top @ up)  # RIM_DEPTH inside the opening
    outer = ray_hit(env, name, np.array([at[0], at[1], top[2] + 0.02]), -1.0)
    middle = (points[:, 2].max() + points[:, 2].min()) / 2
    inner = ray_hit(env, name, np.array([at[0], at[1], middle]), 1.0)
    if outer is None or inner is None or not inner < outer:
        raise OracleFailure(f"no rim grasp on '{name}': cannot find the wall at the top of its opening")
    approach = -up / np.linalg.norm(up)
    closing = np.array([0.0, 0.0, 1.0])
    rotation = np.stack([np.cross(closing, approach), closing, approach], axis=1)
    return np.concatenate([[at[0], at[1], (inner + outer) / 2], matrix_to_quaternion(rotation)])


def turned_rim_grasps(env: RoboLabEnv, name: str, grasp: np.ndarray) -> list[np.ndarray]:
    """The rim grasp `grasp` of lying container `name` (fingers closing vertically on the top of its wall) and the
    same grasp with the hand turned about the vertical through the TCP by RIM_YAWS (the pads stay flat on the wall)
    and its wrist raised by RIM_PITCHES: those whose hand keeps clear of every other object first, then the least
    raised, then the least turned (a standing mug on the line of the lying one's axis blocks the straight-in
    hand)."""
    boxes = []
    for other in env.objects:
        if other != name and not env.eval_context.entries[other].is_fixture:
            points = world_points(env, other)
            boxes.append((points.min(axis=0) - NEIGHBOUR_MARGIN, points.max(axis=0) + NEIGHBOUR_MARGIN))
    rotation = quat_to_matrix(grasp[3:])
    side = rotation[:, 0] * (1.0 if np.cross(rotation[:, 0], rotation[:, 2])[2] < 0 else -1.0)  # raises the wrist
    found = []
    for pitch_rank, pitch in enumerate(RIM_PITCHES):
        lifted = rotation_about(side, np.radians(pitch)) @ rotation
        for yaw_rank, yaw in enumerate(RIM_YAWS):
            turned_rotation = rotation_about(np.array([0.0, 0.0, 1.0]), np.radians(yaw)) @ lifted
            pose = np.concatenate([grasp[:3], matrix_to_quaternion(turned_rotation)])
            hand = hand_points(pose)
            clash = any(bool(np.any(np.all((hand >= low) & (hand <= high), axis=1))) for low, high in boxes)
            found.append((clash, pitch_rank, yaw_rank, pose))
    return [pose for *_, pose in sorted(found, key=lambda item: item[:3])]


# ------------------------------------------------------------------------------------------------ shelves
@dataclass(frozen=True)
class FrontGrasp:
    """A grasp reached from the open side of a shelf: the TCP pose, the pose it comes in from (back along its own
    axis, or straight over it above a wall's rim), the pose outside the shelf (at the height of that one) from
    which the hand moves in, and the horizontal direction (unit x, y) in which the held object is pulled out."""

    pose: np.ndarray
    approach: np.ndarray
    entry: np.ndarray
    out: np.ndarray


def leaning_rotation(closing: np.ndarray, lean: np.ndarray, tilt_angle: float) -> np.ndarray:
    """The TCP rotation of a hand whose fingers close along horizontal `closing` and whose body leans `tilt_angle`
    rad from vertical towards horizontal `lean` (the fingertips point down and away from it)."""
    y = np.array([closing[0], closing[1], 0.0]) / np.linalg.norm(closing[:2])
    z = np.array([-lean[0] * np.sin(tilt_angle), -lean[1] * np.sin(tilt_angle), -np.cos(tilt_angle)])
    return np.stack([np.cross(y, z), y, z], axis=1)


def moved_out(pose: np.ndarray, out: np.ndarray, boxes: list[Box], held: np.ndarray | None = None) -> np.ndarray | None:
    """`pose` moved horizontally along `out` until the hand (and the `held` points, relative to the TCP) is outside
    the footprint of every fixture box, the hand clear of them all the way; None if it would hit one first."""
    tall = [(rotation, middle, half + np.array([0.0, 0.0, 1.0])) for rotation, middle, half in boxes]
    direction = np.array([out[0], out[1], 0.0])
    for distance in np.arange(0.0, PULL_MAX + 1e-9, PULL_STEP):
        moved = shifted(pose, direction * distance)
        if not hand_clear(moved, boxes):
            return None
        inside = inside_boxes(hand_points(moved), tall, HAND_FIXTURE_MARGIN)
        if not inside and (held is None or not inside_boxes(held + moved[:3], tall, HAND_FIXTURE_MARGIN)):
            return moved
    return None


def front_grasps(env: RoboLabEnv, name: str) -> list[FrontGrasp]:
    """Grasps of a covered object (see `world.covered`) by a hand that leans out of the shelf towards the robot,
    least leaning first, each with the hand clear of every fixture at the grasp, on its way in and on the way out.
    A standing container too wide for the fingers is held by its wall at the rim, on the side across the way out,
    the hand coming down onto it from over the rim where it fits there (those first); a long object near its end
    on the open side; anything else across its middle."""
    env.eval_context.refresh()
    boxes = fixture_boxes(env)
    points = world_points(env, name)
    bottom, top = float(points[:, 2].min()), float(points[:, 2].max())
    sides = open_sides(points, boxes)
    wall = env.eval_context.entries[name].is_container and tilt(env, name) < STANDING_TILT
    rim = points[points[:, 2] > top - 0.01]
    rim_centre = (rim[:, :2].max(axis=0) + rim[:, :2].min(axis=0)) / 2
    radius = float(np.linalg.norm(rim[:, :2] - rim_centre, axis=1).max())
    found, over_rims = [], []  # those come down onto a wall from over the rim go first
    for tilt_deg in FRONT_TILTS:
        lean_angle = np.radians(tilt_deg)
        for turn, side_out in ((turn, side_out) for side_out in sides for turn in FRONT_TURNS):
            lean = turned(side_out, turn)
            closing = np.array([-lean[1], lean[0]])
            candidates = []  # (TCP position, closing direction)
            if wall:
                for side in (closing, -closing):
                    walls = wall_along(env, name, rim_centre, side, radius, top)
                    if walls is not None:
                        at = rim_centre + side * sum(walls) / 2
                        candidates.append((np.array([at[0], at[1], top - WALL_GRASP_DEPTH]), side))
            else:
                along, across = points[:, :2] @ lean, points[:, :2] @ closing
                length = float(np.ptp(along))
                at_along = along.max() - FRONT_INSET if length > 4 * FRONT_INSET else (along.max() + along.min()) / 2
                near = np.abs(along - at_along) < FRONT_INSET
                if near.sum() < 2:
                    near = np.ones(len(points), dtype=bool)
                width = float(np.ptp(across[near]))
                if width > MAX_GRASP_WIDTH:
                    continue
                at = lean * at_along + closing * (across[near].max() + across[near].min()) / 2
                drop = pad_drop(width)
                # the pads' lower edge leans with the hand: its lowest corner clear of the level, or (a thin part)
                # its middle FRONT_PAD_BITE below the part's top with the corner at most FRONT_PAD_DIG below its bottom
                part_top = float(points[near, 2].max())
                low = bottom + drop * np.cos(lean_angle) + PAD_HALF_WIDTH * np.sin(lean_angle) + FRONT_PAD_CLEARANCE
                bite = part_top - FRONT_PAD_BITE + drop * np.cos(lean_angle)
                if bite < low:
                    if low - bite > FRONT_PAD_DIG:
                        continue
                    low = bite
                z = max(part_top - GRASP_DEPTH, low)
                candidates.append((np.array([at[0], at[1], z]), closing))
            for position, side in candidates:
                rotation = leaning_rotation(side, lean, lean_angle)
                pose = np.concatenate([position, matrix_to_quaternion(rotation)])
                if not (hand_clear(pose, boxes) and hand_clear(raised(pose, FRONT_LIFT), boxes)):
                    continue
                # a wall is best come down onto from over the rim: in along the hand's axis, the pad that goes
                # inside sweeps across the near rim and pushes the container deeper into the shelf
                over_rim = (
                    raised(pose, WALL_GRASP_DEPTH + pad_corner_drop(lean_angle) + RIM_CLEARANCE) if wall else None
                )
                along_axis = shifted(pose, -rotation[:, 2] * FRONT_APPROACH)
                for approach in (over_rim, along_axis):
                    if approach is None or not hand_clear(approach, boxes):
                        continue
                    entry = moved_out(approach, lean, boxes)
                    if entry is not None:
                        (over_rims if approach is over_rim else found).append(FrontGrasp(pose, approach, entry, lean))
                        break
        if len(over_rims) + len(found) >= FRONT_ENOUGH:
            break
    return over_rims + found


def pad_corner_drop(lean_angle: float) -> float:
    """How far (m) below the TCP the open pads' lowest corner reaches with the hand leaning `lean_angle` rad from
    pointing down."""
    return PAD_BELOW_TCP * np.cos(lean_angle) + PAD_HALF_WIDTH * np.sin(lean_angle)


def ways_out(env: RoboLabEnv, name: str, grasp: FrontGrasp) -> list[np.ndarray]:
    """The TCP poses, FRONT_LIFT above `grasp` and moved horizontally out of the shelf, where the hand and object
    `name` held by it are outside every fixture's footprint: along the grasp's way out first, then out of the
    level's other open sides, nearest that way first; none where the hand would hit a fixture first."""
    points = world_points(env, name)
    boxes = fixture_boxes(env)
    held = points - grasp.pose[:3]
    sides = sorted(open_sides(points, boxes), key=lambda side: -float(side @ grasp.out))
    if not any(np.allclose(side, grasp.out) for side in sides):
        sides.insert(0, grasp.out)
    poses = (moved_out(raised(grasp.pose, FRONT_LIFT), side, boxes, held) for side in sides)
    return [pose for pose in poses if pose is not None]


# ------------------------------------------------------------------------------------------------ boards
BOARD_INSET = 0.03  # m down a leaning board's slope from its raised end where the TCP holds it


def board_end_grasp(env: RoboLabEnv, name: str, board: Board) -> np.ndarray:
    """A grasp [x, y, z, qw, qx, qy, qz] of leaning board `name` at the middle of its raised end, BOARD_INSET in:
    the hand points down the board's slope and the fingers close across its thickness, so that the board can be
    tipped up about its low end without turning in the pads."""
    local = env.eval_context.entries[name].points
    middle = in_world(env, name, ((local.max(axis=0) + local.min(axis=0)) / 2)[None])[0]
    end = middle + board.up * (board.length / 2 - BOARD_INSET)
    approach = -board.up
    rotation = np.stack([np.cross(board.normal, approach), board.normal, approach], axis=1)
    return np.concatenate([end, matrix_to_quaternion(rotation)])


# ------------------------------------------------------------------------------------------------ handles
def side_grips(env: RoboLabEnv, name: str, fits: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
    """Side holds of long tool `name` by its handle (`world.handle_part`) where it lies in a container with its
    handle reaching OVERHANG_MIN out over the wall: (TCP grasp pose, the unit approach direction, level), nearest
    the tool's middle first, from a side of the handle where no other object lies within reach of the hand (a
    top-down hold across a handle packed among others lands a finger on the neighbour); empty where the tool does
    not lie so or both sides are taken. With `fits`, one dummy entry where the tool lies so, whatever is beside
    it."""
    handle = handle_part(env, name)
    container = container_below(env, name)
    if handle is None or container is None:
        return []
    end, direction, length, radius = handle
    if abs(direction[2]) > STANDING_HANDLE:  # a handle standing up: not this hold
        return []
    box = world_points(env, container)
    low, high = box[:, :2].min(axis=0), box[:, :2].max(axis=0)
    ts = np.linspace(0.0, length, HANDLE_SAMPLES)
    axis_points = end + ts[:, None] * direction
    outside = ~np.all((axis_points[:, :2] >= low) & (axis_points[:, :2] <= high), axis=1)
    inside_at = np.flatnonzero(~outside)
    overhang = float(ts[inside_at[0]]) if len(inside_at) else length
    if overhang < OVERHANG_MIN:
        return []
    if fits:  # only whether the tool lies so, whatever is beside its handle
        return [(np.zeros(7), np.zeros(3))]
    others = others_near(env, name, container)
    closing = np.array([0.0, 0.0, 1.0]) - direction[2] * direction  # across the handle, in its vertical plane
    closing /= np.linalg.norm(closing)
    across = np.cross(closing, direction)  # level, across the handle
    grips = []
    for t in (overhang - WALL_MARGIN, (overhang - WALL_MARGIN + END_MARGIN) / 2):
        if t < END_MARGIN:
            continue
        point = end + direction * t
        for sign in (1.0, -1.0):
            approach = sign * across  # the hand moves along this, from the free side into the handle
            rel = others - point
            along = rel @ direction
            lateral = rel @ -approach  # how far on the side the hand comes from
            height = rel @ closing
            near_hand = (
                (np.abs(along) < SIDE_ALONG) & (lateral > 0) & (lateral < SIDE_REACH) & (np.abs(height) < SIDE_HEIGHT)
            )
            beside = (
                (along > -SIDE_ALONG)
                & (along < length - t)
                & (lateral > 0)
                & (lateral < 2 * radius + 2 * PACKED_GAP)
                & (np.abs(height) < 2 * radius)
            )
            if np.any(near_hand | beside):
                continue
            x_axis = np.cross(closing, approach)
            rotation = np.stack([x_axis, closing, approach], axis=1)
            grasp = np.concatenate([point + approach * GRIP_PAST, matrix_to_quaternion(rotation)])
            grips.append((grasp, approach))
    return grips
