"""Top-down grasps: generators of candidate holds with the hand pointing straight down, and the one rule that
picks among them (`grasp_pose`). A grasp is a TCP pose [x, y, z, qw, qx, qy, qz]; a candidate is its position,
height and closing direction with a `GraspScore` (see `scoring`).

The generators, each for what the geometry and the mass of the object call for:
- across a part (`across_candidates`): the fingers closing along the narrowest horizontal direction of the object
  (or of the part nearest its middle, where its middle is empty; or of its top around the centre of mass for a tool
  or a heavy object), turned by GRASP_TURNS and moved along the part by GRASP_SHIFTS, at the height of the widest
  section that fits between the open fingers (`grasp_height`); a tool whose lower hold is walled in is held
  higher (`higher_hold`);
- on the long axis (`centred_grasp`): a light long object's part centred between the pads;
- by the handle beside a heavy end (`balance_grasp`): a tool whose mass centre lies in a wide part (a ladle);
- by a light container's handle (`handle_grasp`);
- across the wall at the rim (`wall_grasp`): a standing container too wide for the open fingers;
- on a chord off the middle (`chord_grasp`): a standing round can as wide as the open fingers or wider;
- at the narrow top end of a lying object (`end_grasp`), for tipping it up.
A grasp whose open fingers would pass through an overhang on the way down is reached sideways from beside it
(`side_step`), and one whose object is as wide as the open fingers first settles just above it (`settle_pose`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.policies.oracle.geometry import down_quaternion, quat_to_matrix, turned
from robolab_ms.policies.oracle.gripper import (
    FINGER_HALF_WIDTH,
    FINGER_TOP,
    HAND_MARGIN,
    HAND_PARTS,
    MAX_GRASP_WIDTH,
    OPEN_FINGER_GAP,
    OPEN_FINGER_REACH,
    PAD_BELOW_TCP,
    PAD_HALF_WIDTH,
    PAD_LENGTH,
    WRIST_HALF,
    pad_drop,
)
from robolab_ms.policies.oracle.scoring import (
    CLASH_COST,
    FINGER_CLASH_TOLERANCE,
    FINGER_SNAG,
    GraspScore,
    blocked,
    clears,
    fixture_closeness,
    grasp_cost,
    hand_clash,
    near_failed,
    pads_snag,
)
from robolab_ms.policies.oracle.world import (
    Grid,
    dense_world_points,
    fixture_boxes,
    footprint_axes,
    footprint_points,
    hits,
    is_heavy,
    is_long,
    is_tool,
    mass,
    mass_centre,
    obstacle_heights,
    ray_hit,
    seen_points,
    standing_container,
    undersides,
    wall_along,
    world_points,
)

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

PART_RADIUS = 0.03  # m: the points around a grasped part that decide its closing direction and height
GRASP_DEPTH = 0.03  # m below an object's top where the TCP (the middle of the finger pads) closes ...
FINGERTIP_CLEARANCE = 0.004  # ... but the closed fingertips at least this high above its bottom (off the table)
SECTION_STEP = 0.005  # m between the heights at which a part's width is measured
FIT_TURN_STEP = 3.0  # degrees between the closing directions tried where the narrowest spread does not fit
SNUG_MARGIN = 0.012  # m: a part held this little narrower than the open fingers' gap is still touched by both pads
SETTLE_CLEARANCE = 0.01  # m between the open pads' lower ends and the top of an object they barely go round
GRASP_TURNS = (0, 15, -15, 30, -30, 45, -45, 60, -60, 75, -75, 90)  # degrees from the narrowest closing direction
MAX_SHIFT_SHARE = 0.3  # a grasp moves along a part by at most this share of its length
GRASP_SHIFTS = (0.0, 0.015, -0.015, 0.03, -0.03, 0.045, -0.045, 0.06, -0.06)  # m along the part from its middle
LONG_MAX_TURN = 30  # degrees: a light long object is closed on at most this far turned from across it
MIN_SLAB_POINTS = 12  # the fewest object points between the fingers that tell the width they close on
# wall grasps
WALL_GRASP_DEPTH = 0.02  # m below the rim where the TCP closes on the wall of a standing container too wide to hold
WALL_GRASP_TURNS = 24  # directions around a standing container tried for a wall grasp
COMFORTABLE_REACH = 0.55  # m from the robot's base where the arm grasps from above most easily
HANDLE_REACH = 0.04  # m beyond a wall where a handle would meet the outer finger ...
HANDLE_HALF_WIDTH = 0.02  # ... within this far to either side of it
# handle grasps of light containers
HANDLE_MAX_MASS = 0.15  # kg: a container this light is held by its handle (a heavier one would twist out of the pads)
HANDLE_RATIO = 1.5  # a footprint at least this many times as long as wide may have a handle at one end ...
HANDLE_MAX_WIDTH = 0.03  # ... where it is at most this wide (m) within HANDLE_END of its end
HANDLE_END = 0.02  # m from the end of the footprint along its long axis: the points that tell the handle's width
HANDLE_INSET = 0.015  # m in from the handle's end where the middle of the pads closes on it
# chord grasps of round cans
ROUNDNESS = 1.08  # a section whose widest spread is at most this many times its narrowest is round
ROUND_DIRECTIONS = 24  # horizontal directions in which the spread is measured for roundness
CHORD_STEP = 0.001  # m between the sideways shifts tried (on a 10-cm can, 2 mm further off the middle let it swing)
CHORD_ROOM = 0.001  # m either side between the open fingers and the widest chord they pass on the way down
RELEASE_ROOM = 0.003  # m either side between the opened pads and the chord they let go of
END_SHARE = 0.2  # the top and the bottom part of an object's height, whose widths are compared with the whole
STRAIGHT_SHARE = 0.95  # a part at least this share of the whole width is as wide
MIN_CHORD_SHARE = 0.6  # the chord held is at least this share of the diameter (the pads' edges keep a hold)
CHORD_NEARNESS_PER_TURN = 0.005  # m of distance from the robot that a step of turn is worth between chord grasps
# balance grasps of tools with a heavy wide end
BALANCE_WIDE = 0.06  # m: a tool this wide (or wider) across at its mass centre is held by a narrower part beside it ...
BALANCE_NARROW = 0.035  # ... at most this wide ...
BALANCE_REACH = 0.08  # ... at most this far (m) from the mass centre along the tool
BALANCE_STEP = 0.005  # m between the places along the tool tried for that narrow part
BALANCE_GAP = 0.01  # m kept between the pads' sides and the wide part
# end grasps of lying objects
END_DEPTHS = np.arange(0.015, 0.08, 0.005)  # m from a lying object's top end where a grasp on its end is tried
END_HALF_SPAN = 0.012  # m: points this near the grasp's line across the axis lie between the pads (their half width)
END_MIN_POINTS = 6  # the fewest surface points between the pads that tell the width there
END_WIDTH_TOLERANCE = 0.002  # m: sections this close to the narrowest count as equally narrow; the middle one is held
# side steps under an overhang
STEP_DISTANCES = (0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.04, 0.05)  # m the hand may step aside, least first
STEP_CLEARANCE = 0.006  # m between the open pads and the object's top while the hand moves in sideways
OVERHANG_MARGIN = 0.01  # m kept between the top of the open fingers and the underside of an overhang

Hold = tuple[float, float, float, float]  # TCP height, width closed on, fingers' clash, the rest of the hand's clash


@dataclass(frozen=True)
class Candidate:
    """A top-down grasp candidate: the TCP's position (x, y) and height, the closing direction (unit x, y), the
    width the fingers close on and its score."""

    xy: np.ndarray
    z: float
    closing: np.ndarray
    width: float
    score: GraspScore


# ------------------------------------------------------------------------------------------------ measures
def grasp_height(slab: np.ndarray, closing: np.ndarray, bottom: float) -> tuple[float, float]:
    """TCP height for fingers closing along `closing` on the object points `slab` between them, and the width
    they close on there. A little below the top; lower where the part is wider further down and still fits between
    the open fingers (round things are held through their middle); the closed pads' lower ends clear of `bottom`."""
    across = slab[:, :2] @ closing
    top = slab[:, 2].max()
    levels = np.arange(top - GRASP_DEPTH, bottom + 2 * SECTION_STEP, -SECTION_STEP)  # the base's own edge aside

    def width_at(level: float) -> float:
        near = np.abs(slab[:, 2] - level) < SECTION_STEP
        return float(np.ptp(across[near])) if near.sum() >= 2 else 0.0

    z, width = levels[0] if len(levels) else top - GRASP_DEPTH, 0.0
    for level in levels:  # down from the default height, while the part still fits between the open fingers
        section = width_at(level)
        if section > MAX_GRASP_WIDTH:
            break
        if section > width + SECTION_STEP or level == levels[0]:  # clearly wider here: hold it here
            z, width = level, section
    width = width or float(np.ptp(across))
    return max(z, bottom + pad_drop(width) + FINGERTIP_CLEARANCE), width


def fitting_direction(points: np.ndarray, narrowest: np.ndarray) -> np.ndarray:
    """`narrowest` (a horizontal unit vector) where the object of world `points` fits between the open fingers
    closing along it; else the horizontal direction across which it is narrowest, found by turning in
    FIT_TURN_STEP steps, if it fits there (a square carton yawed so that its spread has no clear narrowest axis)."""
    xy = points[:, :2]
    if float(np.ptp(xy @ narrowest)) <= MAX_GRASP_WIDTH:
        return narrowest
    angles = np.radians(np.arange(0.0, 180.0, FIT_TURN_STEP))
    candidates = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    widths = np.ptp(xy @ candidates.T, axis=0)
    best = int(widths.argmin())
    return candidates[best] if widths[best] <= MAX_GRASP_WIDTH else narrowest


def closing_directions(points: np.ndarray) -> list[np.ndarray]:
    """The closing directions tried for the object of `points`: its narrowest horizontal direction (one it fits
    across, see `fitting_direction`) turned by each of GRASP_TURNS."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    narrowest = fitting_direction(points, vectors[:, 0])  # a square box: across its faces, not its diagonal
    return [turned(narrowest, angle) for angle in GRASP_TURNS]


def too_wide(points: np.ndarray, closing: np.ndarray, z: float) -> bool:
    """Whether the object, from height `z` up (where the open fingers come down round it), is wider along
    `closing` than the gap between them."""
    near = points[points[:, 2] >= z - 2 * SECTION_STEP]
    if len(near) < 2:  # the grasp is above the object (a thin part lying flat): nothing for the fingers to go round
        return False
    return float(np.ptp(near[:, :2] @ (closing / np.linalg.norm(closing)))) > OPEN_FINGER_GAP


def snug(env: RoboLabEnv, name: str, grasp: np.ndarray) -> bool:
    """Whether the object, at the height of top-down `grasp`, is within SNUG_MARGIN as wide along the closing
    direction as the open fingers' gap (the opened pads still touch it)."""
    points = world_points(env, name)
    closing = quat_to_matrix(grasp[3:])[:, 1]
    slab = points[np.abs(points[:, 2] - grasp[2]) < 2 * SECTION_STEP]
    return len(slab) >= 2 and float(np.ptp(slab @ closing)) > OPEN_FINGER_GAP - SNUG_MARGIN


def spans(points: np.ndarray, at: np.ndarray) -> bool:
    """Whether the open fingers, closing across the object's narrowest horizontal direction at `at`, go round
    all of it there (a spring clamp's two handles)."""
    along, narrowest = footprint_axes(points)
    slab = points[np.abs((points[:, :2] - at[:2]) @ along) < 2 * FINGER_HALF_WIDTH]
    return len(slab) >= 2 and float(np.ptp(slab[:, :2] @ narrowest)) < MAX_GRASP_WIDTH


def round_section(points: np.ndarray) -> bool:
    """Whether the horizontal spread of `points` is about the same in every direction (a can, a cylinder)."""
    angles = np.linspace(0.0, np.pi, ROUND_DIRECTIONS, endpoint=False)
    widths = np.ptp(points[:, :2] @ np.stack([np.cos(angles), np.sin(angles)]), axis=0)
    return float(widths.max()) <= ROUNDNESS * float(widths.min())


def straight_sided(points: np.ndarray) -> bool:
    """Whether the object of `points` is as wide at its top and at its bottom as overall, within STRAIGHT_SHARE (a
    standing can; not a ball or a fruit, whose width the pads meet only at one height, nor a bottle's neck)."""
    low, high = points[:, 2].min(), points[:, 2].max()
    overall = float(np.ptp(points[:, :2], axis=0).min())
    for end in (points[:, 2] >= high - END_SHARE * (high - low), points[:, 2] <= low + END_SHARE * (high - low)):
        if end.sum() < 2 or float(np.ptp(points[end, :2], axis=0).min()) < STRAIGHT_SHARE * overall:
            return False
    return True


def band_offset(footprint: np.ndarray, xy: np.ndarray, closing: np.ndarray) -> tuple[float, float] | None:
    """How far (m) along horizontal unit `closing` the middle of the object part between fingers at `xy` lies from
    `xy`, and how wide it is along `closing`, measured on `footprint` (see `world.footprint_points`); None where
    too little of the object lies between the fingers."""
    along = np.array([-closing[1], closing[0]])
    slab = footprint[np.abs(footprint[:, :2] @ along - xy @ along) < FINGER_HALF_WIDTH]
    if len(slab) < MIN_SLAB_POINTS:
        return None
    across = slab[:, :2] @ closing - xy @ closing
    return float((across.max() + across.min()) / 2), float(np.ptp(across))


def off_part(footprint: np.ndarray | None, xy: np.ndarray, closing: np.ndarray) -> bool:
    """Whether an open finger of a grasp at `xy` closing along `closing` comes down on the object seen from above
    as `footprint`: its part between the fingers reaches past a finger's outer face (False where it cannot be
    measured). That finger reaches the part first and pushes it aside before the other closes."""
    if footprint is None:
        return False
    closing = closing / np.linalg.norm(closing)
    measured = band_offset(footprint, xy, closing)
    return measured is not None and abs(measured[0]) + measured[1] / 2 > OPEN_FINGER_REACH


def heavy_end(env: RoboLabEnv, name: str) -> tuple[np.ndarray, float, np.ndarray] | None:
    """For a long tool whose mass centre lies in (or at the edge of) a part at least BALANCE_WIDE across (a
    ladle's bowl): the mass centre (x, y, z), the half width of that part and the horizontal unit vector from the
    mass centre towards the tool's middle (along the handle); None for any other object."""
    points = world_points(env, name)
    if not is_tool(env, name, points):
        return None
    points = seen_points(env, name)
    centre_of_mass = mass_centre(env, name)
    long, narrow = footprint_axes(points)
    along = (points[:, :2] - centre_of_mass[:2]) @ long
    at = np.abs(along) < 2 * FINGER_HALF_WIDTH  # where the pads of a grasp at the mass centre reach
    if at.sum() < 2:
        return None
    width = float(np.ptp(points[at, :2] @ narrow))
    if width < BALANCE_WIDE:
        return None
    middle = (points.max(axis=0) + points.min(axis=0)) / 2
    towards = long if float((middle[:2] - centre_of_mass[:2]) @ long) >= 0.0 else -long
    return centre_of_mass, width / 2, towards


# ------------------------------------------------------------------------------------------------ generators
def across_candidates(
    env: RoboLabEnv,
    name: str,
    points: np.ndarray,
    footprint: np.ndarray | None,
    middle: np.ndarray,
    directions: list[np.ndarray],
    bottom: float,
    heights: Grid | None,
    part_only: bool,
    tool: bool,
    failed: list[np.ndarray],
) -> Iterator[Candidate]:
    """Top-down candidates across a part of object `name` (world `points`, its top mapped as `footprint` where it
    has few points of its own): the fingers closing along each of `directions` (in order of preference), the hand
    over `middle` or (unless `part_only`, a part of an object whose middle is empty) moved along the part by
    GRASP_SHIFTS, at `grasp_height`. A clash of the open fingers with an overhang that the hand can come in under
    sideways (`side_step`) does not count; a `tool` (long and heavy, or heavy) whose hold is walled in is held
    higher (`higher_hold`). Scored: what the hand's way down hits beyond what it pushes aside, then (for an object
    that is not long) a finger coming down on a neighbour or a part too wide, and (for a light long one) the
    closing pads pinching a neighbour, a part too wide or a turn beyond LONG_MAX_TURN, then moved at all, then
    the cost of shift, turn, clash and width; candidates near a grasp in `failed` come last."""
    long = is_long(points)
    for turn_rank, direction in enumerate(directions):
        direction = direction / np.linalg.norm(direction)
        along = np.array([-direction[1], direction[0]])  # the hand's x axis: the fingers' width runs along it
        reach = points[:, :2] @ along - middle[:2] @ along
        limit = MAX_SHIFT_SHARE * float(np.ptp(reach))
        shifts = [0.0] if part_only else [v for v in GRASP_SHIFTS if abs(v) <= limit]
        for shift in shifts or [0.0]:
            xy = middle[:2] + along * shift
            slab = points[np.abs(points[:, :2] @ along - xy @ along) < FINGER_HALF_WIDTH]
            if len(slab) < MIN_SLAB_POINTS and footprint is not None:  # a box has only its corners: the top seen
                slab = footprint[np.abs(footprint[:, :2] @ along - xy @ along) < FINGER_HALF_WIDTH]  # from above
            if len(slab) < MIN_SLAB_POINTS:  # too few surface points there to measure
                slab = points
            z, width = grasp_height(slab, direction, bottom)
            fingers, body = hand_clash(heights, xy, direction, z)
            if fingers > FINGER_CLASH_TOLERANCE and side_step(env, name, xy, direction, z, heights) is not None:
                fingers = 0.0  # an overhang the hand comes in under from the side
            if tool and fingers > FINGER_CLASH_TOLERANCE:  # its widest part walled in (a drill's battery in a bin)
                z, width, fingers, body = higher_hold(slab, direction, heights, xy, (z, width, fingers, body))
            if long and not tool:  # moved or turned where that keeps the closing pads off a neighbour (a plate)
                snag = (
                    width > MAX_GRASP_WIDTH
                    or pads_snag(heights, xy, direction, z, width)
                    or abs(GRASP_TURNS[turn_rank]) > LONG_MAX_TURN
                )
            else:  # a finger comes down on a neighbour, or the part does not fit (a long tool: across it)
                snag = not long and (fingers > FINGER_SNAG or width > MAX_GRASP_WIDTH)
            score = GraspScore(
                failed_nearby=near_failed(xy, direction, failed),
                blocked=blocked(fingers, body),
                snag=snag,
                moved=shift != 0.0 or turn_rank > 0,
                cost=grasp_cost(shift, turn_rank, fingers, body, width),
            )
            yield Candidate(xy, z, direction, width, score)


def higher_hold(slab: np.ndarray, closing: np.ndarray, heights: Grid | None, xy: np.ndarray, lower: Hold) -> Hold:
    """A top-down hold of a tool at (x, y) `xy`, the fingers closing along `closing` (horizontal unit vector),
    GRASP_DEPTH below the top of `slab` (the tool's world points between the fingers): the TCP height, the width
    the fingers close on there (the slab from just below that height up), and how far anything else rises into
    the space of the fingers and of the rest of the hand. `lower` (the hold `grasp_height` found, in the same
    terms) where that one is not lower (a flat tool). A drill standing in a bin is widest at its battery, down by
    the floor, where the open fingers would meet the bin's walls: it is held across its body higher up instead."""
    z = float(slab[:, 2].max()) - GRASP_DEPTH
    if z <= lower[0] + SECTION_STEP:
        return lower
    section = slab[slab[:, 2] >= z - 2 * SECTION_STEP]
    width = float(np.ptp(section[:, :2] @ closing)) if len(section) >= 2 else 0.0
    fingers, body = hand_clash(heights, xy, closing, z)
    return z, width, fingers, body


def centred_grasp(
    footprint: np.ndarray, directions: list[np.ndarray], bottom: float, heights: Grid | None
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """(xy, z, closing) of a top-down grasp of a light long object seen from above as `footprint`: the hand on the
    object's long axis, moved along it by one of GRASP_SHIFTS, closing along one of `directions` (the turns of
    GRASP_TURNS, in order), and then moved along the closing direction until the part between the fingers is
    centred. Of these the one whose open fingers and hand clear the neighbours (obstacle grid `heights`), then
    whose closing pads pinch none and which is turned at most LONG_MAX_TURN from across the object, then the
    nearest the middle and least turned; None where every one is blocked."""
    xy_all = footprint[:, :2]
    middle = (xy_all.max(axis=0) + xy_all.min(axis=0)) / 2
    axis, _ = footprint_axes(footprint)
    limit = MAX_SHIFT_SHARE * float(np.ptp(xy_all @ axis))
    best: Candidate | None = None
    for turn_rank, direction in enumerate(directions):
        direction = direction / np.linalg.norm(direction)
        along = np.array([-direction[1], direction[0]])
        for shift in [v for v in GRASP_SHIFTS if abs(v) <= limit]:
            xy = middle + axis * shift
            measured = band_offset(footprint, xy, direction)
            if measured is None or measured[1] > MAX_GRASP_WIDTH:
                continue
            xy = xy + direction * measured[0]
            slab = footprint[np.abs(footprint[:, :2] @ along - xy @ along) < FINGER_HALF_WIDTH]
            z, width = grasp_height(slab, direction, bottom)
            fingers, body = hand_clash(heights, xy, direction, z)
            snag = (
                width > MAX_GRASP_WIDTH
                or pads_snag(heights, xy, direction, z, width)
                or (abs(GRASP_TURNS[turn_rank]) > LONG_MAX_TURN)
            )  # turned far from across it
            score = GraspScore(
                failed_nearby=False,
                blocked=blocked(fingers, body),
                snag=snag,
                moved=False,
                cost=grasp_cost(shift, turn_rank, fingers, body),
            )
            if best is None or score.key < best.score.key:
                best = Candidate(xy, z, direction, width, score)
    if best is None or best.score.blocked > 0.0:
        return None
    return best.xy, best.z, best.closing


def balance_grasp(env: RoboLabEnv, name: str, failed: list[np.ndarray] = ()) -> np.ndarray | None:
    """A top-down grasp of a tool with a heavy wide end (see `heavy_end`) by its narrow part nearest the mass
    centre, the fingers closing across it at the height of its middle (the closed pads' lower ends clear of the
    table), the nearest one not near a grasp in `failed`; None for other objects, or where no narrow part within
    BALANCE_REACH is clear of the neighbours and of `failed`. Held at its mass centre such a tool is held by the
    wide part, which the open fingers barely go round: it turns out of the pads as it is lifted."""
    if env.scene.gpu_sim_enabled:
        return None
    found = heavy_end(env, name)
    if found is None:
        return None
    centre_of_mass, _, towards = found
    points = seen_points(env, name)
    across = np.array([-towards[1], towards[0]])
    along = (points[:, :2] - centre_of_mass[:2]) @ towards
    bottom = float(points[:, 2].min())
    heights = obstacle_heights(env, name, centre_of_mass[:2])
    offset = (points[:, :2] - centre_of_mass[:2]) @ across
    wide = np.abs(offset - np.median(offset)) > BALANCE_NARROW / 2
    wide_end = float(along[wide].max(initial=0.0))  # where the wide part ends towards the handle
    half = FINGER_HALF_WIDTH + BALANCE_GAP  # the wide part stays this far from the middle of the pads
    for distance in np.arange(max(wide_end + half, BALANCE_STEP), BALANCE_REACH + 1e-9, BALANCE_STEP):
        slab = points[np.abs(along - distance) < FINGER_HALF_WIDTH]
        if len(slab) < 2 or float(np.ptp(slab[:, :2] @ across)) > BALANCE_NARROW:
            continue
        width = float(np.ptp(slab[:, :2] @ across))
        middle_across = (float((slab[:, :2] @ across).max()) + float((slab[:, :2] @ across).min())) / 2
        xy = centre_of_mass[:2] + towards * distance
        xy = xy + across * (middle_across - float(xy @ across))
        top = float(slab[:, 2].max())
        under = ray_hit(env, name, np.array([xy[0], xy[1], bottom + 0.001]), 1.0)  # a handle held up
        underside = bottom if under is None or under >= top else under
        z = max((top + underside) / 2, bottom + pad_drop(width) + FINGERTIP_CLEARANCE)
        fingers, body = hand_clash(heights, xy, across, z)
        if not clears(fingers, body):
            continue
        if failed and near_failed(xy, across, list(failed)):
            continue  # further along the handle (one near the balance point may be out of reach)
        return np.concatenate([[xy[0], xy[1], z], down_quaternion(across)])
    return None


def handle_grasp(env: RoboLabEnv, name: str, heights: Grid | None) -> np.ndarray | None:
    """A top-down grasp of the handle of container `name` near its outer end, fingers closing across it at the
    height of its middle; None where `name` is not a light container with a handle (a narrow end of an elongated
    footprint) or where the hand coming down there would hit a neighbour. `heights`: the obstacle grid (None off
    the CPU simulator: no handle grasp). A wall grasp touches the wall with one pad first, which pushes a light
    vessel over before the other pad arrives; around a narrow handle both pads come down clear of it."""
    entry = env.eval_context.entries[name]
    if heights is None or not entry.is_container or mass(env, name) > HANDLE_MAX_MASS:
        return None
    points = world_points(env, name)
    long, narrow = footprint_axes(points)
    along, across = points[:, :2] @ long, points[:, :2] @ narrow
    if float(np.ptp(along)) < HANDLE_RATIO * float(np.ptp(across)):
        return None
    best = None
    for end, sign in ((along.max(), 1.0), (along.min(), -1.0)):
        tip = sign * (along - end) > -HANDLE_END  # the points within HANDLE_END of this end
        if tip.sum() < 2 or float(np.ptp(across[tip])) > HANDLE_MAX_WIDTH:
            continue
        at_along = end - sign * HANDLE_INSET
        at_across = (across[tip].max() + across[tip].min()) / 2
        z = float((points[tip, 2].max() + points[tip, 2].min()) / 2)
        position = long * at_along + narrow * at_across
        fingers, body = hand_clash(heights, position, narrow, z)
        if not clears(fingers, body):
            continue
        if best is None or fingers + body < best[0]:
            best = (fingers + body, position, z)
    if best is None:
        return None
    _, position, z = best
    return np.concatenate([[position[0], position[1], z], down_quaternion(narrow)])


def wall_grasp(env: RoboLabEnv, name: str, heights: Grid | None) -> np.ndarray | None:
    """A top-down grasp of a standing container too wide for the open fingers (a mug, a bowl): the fingers straddle
    its wall at the rim, one inside and one outside, closing across the wall. Of the directions around it, the one
    whose hand clears the container's own handle, then the neighbours, then stays away from a fixture beside it
    (`fixture_closeness`), at the distance from the robot's base that the arm reaches most easily; None where no
    wall is found."""
    points = world_points(env, name)
    top = float(points[:, 2].max())
    rim = points[points[:, 2] > top - 0.01]
    middle = (rim[:, :2].max(axis=0) + rim[:, :2].min(axis=0)) / 2
    radius = float(np.linalg.norm(rim[:, :2] - middle, axis=1).max())
    best, best_key = None, None
    fixtures = [] if env.scene.gpu_sim_enabled else fixture_boxes(env)
    for index in range(WALL_GRASP_TURNS):
        angle = 2 * np.pi * index / WALL_GRASP_TURNS
        outward = np.array([np.cos(angle), np.sin(angle)])
        wall = wall_along(env, name, middle, outward, radius, top)
        if wall is None:
            continue
        inner, outer = wall
        xy = middle + outward * (inner + outer) / 2
        z = top - WALL_GRASP_DEPTH
        beyond = points[:, :2] - middle
        radial, tangential = beyond @ outward, np.abs(beyond @ np.array([-outward[1], outward[0]]))
        handle = bool(
            np.any(
                (radial > outer + HAND_MARGIN)
                & (radial < outer + HANDLE_REACH)
                & (tangential < HANDLE_HALF_WIDTH)
                & (points[:, 2] > z - PAD_LENGTH)
            )
        )
        fingers, body = hand_clash(heights, xy, outward, z)
        comfort = abs(float(np.linalg.norm(xy)) - COMFORTABLE_REACH)  # then the side the arm reaches most easily
        near = round(fixture_closeness(fixtures, xy, z), 2)  # away from a shelf beside it, where the arm passes it
        key = (handle, fingers + body > 0.01, near, round(fingers + body, 3), comfort)
        if best_key is None or key < best_key:
            best, best_key = (xy, z, outward), key
    if best is None:
        return None
    xy, z, outward = best
    return np.concatenate([[xy[0], xy[1], z], down_quaternion(outward)])


def chord_grasp(
    env: RoboLabEnv,
    name: str,
    points: np.ndarray,
    middle: np.ndarray,
    directions: list[np.ndarray],
    bottom: float,
    heights: Grid | None,
    failed: list[np.ndarray],
    through_height: float,
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """(xy, z, closing) of a grasp of the round object `name` (world `points`, footprint middle `middle`) off its
    middle, as near the middle as the open fingers pass the can and let go of it: the widest chord between the
    fingers (FINGER_HALF_WIDTH either side of their line; a circle of the object's radius, as its surface points may
    be sparse) leaves CHORD_ROOM either side of them open, and the chord where the pads press (their edge nearest
    the middle, PAD_HALF_WIDTH off their line) RELEASE_ROOM either side of the opened pads; None where
    the object is no standing can (`round_section`, `straight_sided`), a grasp through its middle at TCP height
    `through_height` fits (what lies lower stays below the fingers: a bottle's neck), or no chord does. Of the
    closing `directions` and the two sides, the one whose hand clears the neighbours best, then the one away from
    grasps in `failed`, then the nearest to the robot (the arm reaches it most easily). A can as wide
    as the open fingers, held through its middle, stays between the opened pads (they still press on it); a pair of
    pads moved sideways off the middle closes on a narrower chord. The further off the middle, the weaker the hold:
    the squeeze pushes the can out along the pads, and its weight turns it about the line between the pads (a
    10.2-cm can pressed by the pads' edges 3.4 cm off its axis rises, 3.6 cm off it swings down out of the pads);
    no chord narrower than MIN_CHORD_SHARE of the diameter is tried."""
    if env.eval_context.entries[name].is_container or not round_section(points) or not straight_sided(points):
        return None
    radius = float(np.linalg.norm(points[:, :2] - middle[:2], axis=1).max())
    best, best_key = None, None
    for rank, direction in enumerate(directions):
        direction = direction / np.linalg.norm(direction)
        along = np.array([-direction[1], direction[0]])
        offsets = points[:, :2] @ along - middle[:2] @ along
        around = points[:, 2] >= through_height - 2 * SECTION_STEP  # where the open fingers come down round it
        through_middle = points[(np.abs(offsets) < FINGER_HALF_WIDTH) & around]
        if len(through_middle) >= 2 and float(np.ptp(through_middle[:, :2] @ direction)) <= MAX_GRASP_WIDTH:
            return None  # it fits through the middle: the grasp across it
        for side in (1.0, -1.0):
            for shift in np.arange(FINGER_HALF_WIDTH, radius + FINGER_HALF_WIDTH, CHORD_STEP):
                passed = circle_chord(radius, shift - FINGER_HALF_WIDTH)  # the fingers' edge nearest the middle
                pressed = circle_chord(radius, shift - PAD_HALF_WIDTH)  # the pads' edge nearest the middle
                if pressed < MIN_CHORD_SHARE * 2 * radius:
                    break
                if passed > OPEN_FINGER_GAP - 2 * CHORD_ROOM or pressed > OPEN_FINGER_GAP - 2 * RELEASE_ROOM:
                    continue
                xy = middle[:2] + along * side * shift
                slab = points[np.abs(offsets - side * shift) < FINGER_HALF_WIDTH]
                z, _ = grasp_height(slab if len(slab) >= MIN_SLAB_POINTS else points, direction, bottom)
                fingers, body = hand_clash(heights, xy, direction, z)
                key = (
                    round(CLASH_COST * (fingers + body), 3),
                    near_failed(xy, direction, failed),
                    float(np.linalg.norm(xy)) + CHORD_NEARNESS_PER_TURN * rank,
                )
                if best_key is None or key < best_key:
                    best, best_key = (xy, z, direction), key
                break
    return best


def circle_chord(radius: float, offset: float) -> float:
    """The length of the chord of a circle of `radius` at `offset` from its middle (0 beyond the circle)."""
    return 2.0 * float(np.sqrt(max(radius**2 - offset**2, 0.0)))


def end_grasp(env: RoboLabEnv, name: str, up: np.ndarray) -> np.ndarray | None:
    """A top-down grasp of the top end of lying object `name` (the end its up axis `up` points to): the fingers
    close horizontally across its axis on the narrowest section near that end that fits between the open fingers
    (a jug's neck), in the middle of the run of sections about as narrow; None if none fits."""
    env.eval_context.refresh()
    points = world_points(env, name)
    flat = np.array([up[0], up[1]], dtype=np.float64)
    flat /= np.linalg.norm(flat)
    closing = np.array([-flat[1], flat[0]])
    along, across = points[:, :2] @ flat, points[:, :2] @ closing
    end, bottom = float(along.max()), float(points[:, 2].min())
    sections = []  # (width, depth)
    for depth in END_DEPTHS:
        near = np.abs(along - (end - depth)) < END_HALF_SPAN
        if near.sum() >= END_MIN_POINTS and np.ptp(across[near]) <= MAX_GRASP_WIDTH:
            sections.append((float(np.ptp(across[near])), float(depth)))
    if not sections:
        return None
    narrowest = min(width for width, _ in sections)
    depths = [depth for width, depth in sections if width <= narrowest + END_WIDTH_TOLERANCE]
    depth = depths[len(depths) // 2]
    slab = points[np.abs(along - (end - depth)) < END_HALF_SPAN]
    mid = (float((slab[:, :2] @ closing).max()) + float((slab[:, :2] @ closing).min())) / 2
    xy = flat * (end - depth) + closing * mid
    z, _ = grasp_height(slab, closing, bottom)
    return np.concatenate([[xy[0], xy[1], z], down_quaternion(closing, keep_sign=True)])


# ------------------------------------------------------------------------------------------------ approaches
def side_step(
    env: RoboLabEnv, name: str, xy: np.ndarray, closing: np.ndarray, z: float, heights: Grid | None
) -> np.ndarray | None:
    """The horizontal offset (x, y) of the pose above a top-down grasp of `name` at (xy, z), fingers closing along
    `closing`, from which the hand comes in sideways under an overhang (a keyboard leaning over a bin's rim above
    a phone beside it): coming straight down, an open finger would pass through the overhang, although at the
    grasp itself the fingers are well below it. None where the way straight down is clear, where something other
    than an overhang high enough is in the fingers' way (or over the gripper's body), or where no step of at most
    the largest of STEP_DISTANCES clears it. `heights`: the obstacle grid (None off the CPU simulator)."""
    if heights is None:
        return None
    cells, tops = heights
    closing = np.asarray(closing[:2], dtype=np.float64) / np.linalg.norm(closing[:2])
    along = np.array([-closing[1], closing[0]])
    half_u, half_v, reach = HAND_PARTS[0]
    local = cells - xy
    u, v = np.abs(local @ along), local @ closing
    margin = HAND_MARGIN
    in_way = (u <= half_u + margin) & (np.abs(v) <= half_v + margin) & (tops > z - reach)
    if not in_way.any():
        return None
    body = (u <= WRIST_HALF + margin) & (np.abs(v) <= WRIST_HALF + margin) & (tops > z + HAND_PARTS[1][2])
    if body.any():  # the gripper's body or the wrist over the grasp would hit it: no way in
        return None
    sides = np.sign(v[in_way])
    if np.any(sides != sides[0]) or sides[0] == 0.0:  # on both sides of the hand
        return None
    points = world_points(env, name)
    low = max(z, float(points[:, 2].max()) + PAD_BELOW_TCP + STEP_CLEARANCE)
    if undersides(env, name, cells[in_way]).min() < low + FINGER_TOP + OVERHANG_MARGIN:
        return None  # not an overhang, or one too low to reach under
    away = -sides[0] * closing
    for distance in STEP_DISTANCES:
        if hand_clash(heights, xy + away * distance, closing, low) == (0.0, 0.0):
            return away * distance
    return None


def side_step_path(env: RoboLabEnv, name: str, grasp: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """For the top-down grasp `grasp` of `name`: the TCP pose beside it from which the hand comes in sideways under
    an overhang (see `side_step`), and the pose just above the grasp it moves in to (both at the height where the
    open pads clear the object's top); None where the hand comes straight down."""
    rotation = quat_to_matrix(grasp[3:])
    if abs(rotation[2, 2] + 1.0) > 1e-3:  # only a hand pointing straight down
        return None
    heights = obstacle_heights(env, name, grasp[:2])
    offset = side_step(env, name, grasp[:2], rotation[:2, 1], float(grasp[2]), heights)
    if offset is None:
        return None
    points = world_points(env, name)
    low = max(float(grasp[2]), float(points[:, 2].max()) + PAD_BELOW_TCP + STEP_CLEARANCE)
    over = grasp.copy()
    over[2] = low
    beside = over.copy()
    beside[:2] += offset
    return beside, over


def settle_pose(env: RoboLabEnv, name: str, grasp: np.ndarray) -> np.ndarray:
    """`grasp` raised until the open pads' lower ends are SETTLE_CLEARANCE above the top of object `name`: where
    the hand waits for the arm to catch up before going down round an object as wide as the open fingers (see
    `snug`), which a pad lagging a few millimetres behind would land on."""
    pose = grasp.copy()
    pose[2] = max(grasp[2], float(world_points(env, name)[:, 2].max()) + PAD_BELOW_TCP + SETTLE_CLEARANCE)
    return pose


# ------------------------------------------------------------------------------------------------ the rule
def grasp_pose(
    env: RoboLabEnv,
    name: str,
    closing: np.ndarray | None = None,
    keep_sign: bool = False,
    failed: list[np.ndarray] = (),
) -> np.ndarray:
    """The top-down grasp [x, y, z, qw, qx, qy, qz] of the TCP for object `name`, the fingers closing along
    `closing` if given. The rule, from the object's geometry and mass:

    1. a tool with a heavy wide end: by the narrow part beside it (`balance_grasp`);
    2. otherwise the best of `across_candidates` (`GraspScore.key`), centred on the object's footprint, on its
       centre of mass for a tool or a heavy object (held far from it, it twists out of the pads), or on the part
       nearest the middle where nothing of the object is there (a ring, a pair of glasses);
    3. a light long object whose best candidate leaves its part under an open finger: the best `centred_grasp`;
    4. a light standing container with a handle: `handle_grasp`; one too wide for the open fingers: `wall_grasp`;
    5. a round standing can that fits no grasp through its middle: `chord_grasp`.

    Candidates near a grasp in `failed` (earlier grasps of this object whose job did not succeed) come after all
    others, and after a failure the widths are measured on the collision hulls' faces too (between a mesh's hull
    corners a slab can look thin). Unless `keep_sign`, of the two ways round the hand the one pointing away from
    the robot."""
    env.eval_context.refresh()
    points = world_points(env, name)
    if len(failed):  # a grasp failed: measure on the faces too
        points = np.concatenate([points, dense_world_points(env, name)])
    bottom = points[:, 2].min()  # of the whole object: what the fingertips must stay clear of is below it
    middle = (points.max(axis=0) + points.min(axis=0)) / 2
    part_only = not hits(env, name, middle[:2], points[:, 2].max())
    tool = is_tool(env, name, points) or is_heavy(env, name)  # held at its centre of mass
    if tool and closing is None:
        balanced = balance_grasp(env, name, failed)
        if balanced is not None:
            return balanced
    if tool:
        centre_of_mass = mass_centre(env, name)
        seen = footprint_points(env, name, points)
        if hits(env, name, centre_of_mass[:2], points[:, 2].max()) or spans(
            points if seen is None else seen, centre_of_mass
        ):
            middle, part_only = np.array([centre_of_mass[0], centre_of_mass[1], middle[2]]), False
    if part_only:  # the middle is empty: grasp the part of the object nearest to it
        mapped = footprint_points(env, name, points)  # a primitive's corners may all lie far from that part
        if mapped is not None and len(mapped) >= MIN_SLAB_POINTS:
            nearest = mapped[np.linalg.norm(mapped[:, :2] - middle[:2], axis=1).argmin()]
            points = np.concatenate([points, mapped])
        else:
            nearest = points[np.linalg.norm(points[:, :2] - middle[:2], axis=1).argmin()]
        points = points[np.linalg.norm(points[:, :2] - nearest[:2], axis=1) < PART_RADIUS]
        middle = np.array([nearest[0], nearest[1], (points[:, 2].max() + points[:, 2].min()) / 2])
    footprint = footprint_points(env, name, points) if tool and not part_only else None  # a tool's top, mapped
    if closing is None:
        directions = closing_directions(points if footprint is None or len(footprint) < MIN_SLAB_POINTS else footprint)
    else:
        directions = [np.asarray(closing[:2], dtype=np.float64)]
    heights = obstacle_heights(env, name, middle[:2])
    long = is_long(points)
    candidates = across_candidates(
        env, name, points, footprint, middle, directions, bottom, heights, part_only, tool, list(failed)
    )
    best = min(candidates, key=lambda candidate: candidate.score.key)
    xy, z, direction = best.xy, best.z, best.closing
    if long and not tool and closing is None and heights is not None and not part_only:
        seen = footprint_points(env, name, points)
        if off_part(seen, xy, direction):
            xy, z, direction = centred_grasp(seen, directions, bottom, heights) or (xy, z, direction)
    # a wall grasp needs ray casts, which the oracle does only on the CPU simulator (where `heights` exist)
    wide = closing is None and heights is not None and too_wide(points, direction, z)
    standing = closing is None and heights is not None and not tool and standing_container(env, name)
    handle = handle_grasp(env, name, heights) if standing else None
    if handle is not None:
        return handle
    if wide and standing_container(env, name):
        wall = wall_grasp(env, name, heights)
        if wall is not None:
            return wall
    if closing is None and heights is not None and not tool and not part_only and not long:
        chord = chord_grasp(env, name, points, middle, directions, bottom, heights, list(failed), z)
        if chord is not None:
            xy, z, direction = chord
    return np.concatenate([[xy[0], xy[1], z], down_quaternion(direction, keep_sign)])
