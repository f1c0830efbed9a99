"""Reusable skills: whole manipulations planned from the state the oracle finds and queued on a `MotionPlanner`.

- `pick_and_place`: a top-down grasp, the lift, the carry over what stands on the way and the release at a free
  spot (or a lift alone), with the approaches a grasp calls for (in sideways under an overhang, settling over an
  object as wide as the open fingers, from lower down for a heavy tool at the edge of the reach, drawn nearer
  before it is lifted) and the exits (slid off an object as wide as the open fingers, in from the front onto a
  high shelf);
- `front_pick_and_place`: an object under a shelf level, grasped by a hand leaning in from the open side and
  pulled straight out;
- `side_hold_pick_and_place`: a long tool held by its handle from the side where it reaches out of a container;
- `lift_out_standing`: a board leaning in a container stood up on its end, lifted out and laid on the table;
- `stand_upright`: a lying object stood up, tipped about its base (`pivot_upright`, holding a container's rim or
  a narrow end) or lifted and turned in the air (`lift_and_turn_upright`);
- `tip_onto_side`: an object standing upside down pushed over at its top edge onto its side, from where
  `stand_upright` stands it up (a regrasp in two quarter turns; a mug wider than the open fingers has no grasp
  that turns it over in one).
A skill raises OracleFailure where it cannot be planned, and then leaves nothing of itself queued.
"""

from __future__ import annotations

from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.policies.oracle.clearance import APPROACH_HEIGHT, LIFT_HEIGHT, above, held_spread, high_carry
from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.geometry import (
    down_quaternion,
    in_frame,
    matrix_to_quaternion,
    quat_to_matrix,
    raised,
    rolled,
    rotation_about,
    rotation_between,
    shifted,
)
from robolab_ms.policies.oracle.grasps import (
    end_grasp,
    grasp_pose,
    settle_pose,
    side_step_path,
    snug,
)
from robolab_ms.policies.oracle.motion import GRIPPER_STEPS, IK_RETRIES, MotionPlanner, any_posture
from robolab_ms.policies.oracle.places import (
    RELEASE_CLEARANCE,
    Reachable,
    Spot,
    free_place,
    head_first_place,
    place_pose,
    shared_place,
    standing_spot,
    turned_place,
    turned_table_place,
)
from robolab_ms.policies.oracle.side_grasps import (
    FRONT_LIFT,
    FrontGrasp,
    board_end_grasp,
    front_grasps,
    moved_out,
    rim_grasp,
    turned_rim_grasps,
    ways_out,
)
from robolab_ms.policies.oracle.world import (
    UPSIDE_DOWN_TILT,
    Board,
    centre,
    container_below,
    fixture_boxes,
    handle_part,
    is_heavy,
    is_tool,
    object_bottom,
    tilt,
    world_points,
)

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

BACK_OFF = 0.06  # m the hand backs away (and rises) after setting an object down upright
SLIDE_OFF = 0.012  # m the hand moves along the closing direction after letting go of an object as wide as the fingers
STEP_SETTLE_STEPS = 12  # control steps held for the lagging arm to catch up before a move that must start where
# planned: a descent of millimetres, a straight move into a lying container's opening
STEP_LIFT = 0.01  # m the held object is raised off the table before the hand moves back out sideways
PIVOT_STEPS = 6  # straight moves that tip a lying object up about its base
PIVOT_HOLD_STEPS = 15  # control steps the hand keeps its grip at the end of a tip, for the lagging arm to finish it
RIM_APPROACH = 0.06  # m outside a lying container's opening from where the hand moves straight in to the rim
BASE_BAND = 0.01  # m above the lowest point along a lying object's axis that counts as its base
FRONT_PLACE_RISE = 0.02  # m above the release that an object is slid in over a high shelf from the front ...
FRONT_PLACE_LEAVE = 0.05  # ... and the hand rises over the release before it leaves
TOOL_REACH = 0.765  # m from the robot's base (horizontally) within which the arm lifts a tool held from above
APPROACH_STEP = 0.01  # m between the heights tried for the pose a far tool is reached from ...
APPROACH_LOWEST = 0.03  # ... down to this far above the grasp ...
APPROACH_BACKS = (0.0, 0.02, 0.04)  # ... at each height first over the grasp, then drawn back this far (m)
DRAW_RISE = 0.01  # m a far tool is raised off the floor while it is drawn nearer ...
DRAW_MAX = 0.05  # ... by at most this far
SIDE_APPROACHES = (0.10, 0.07, 0.05)  # m from a side hold, level across the handle, where the hand starts in
SIDE_SLIDE_PAST = 0.03  # m beyond a handle's free end from where the hand may slide on along it into a side hold
SIDE_LIFT_CLEARANCE = 0.03  # m the tool, hanging straight down from a side hold, is lifted above its container
SIDE_LIFT_MIN = 0.15  # m the tool held from the side is lifted at least
SIDE_BACK_OUT = 0.08  # m the hand backs out along its approach after letting go of a side hold
SIDE_RETREAT = 0.05  # m the hand rises after backing out
RISE_STEP = 0.04  # m per straight move of a lift from a side hold
LAY_GAP = 0.005  # m above the table that a tool hanging from a side hold is let down to ...
LAY_ANGLE = np.radians(75.0)  # ... before it is turned this far over about the edge of its lower end and let go
LAY_BASE = 0.01  # m above a hanging tool's lowest point that its lower end's edge is looked for
SWING_END = 0.1  # m from the farthest point of a tool swinging from a side hold that its far end spans
SWING_WALL = 0.01  # m inside a container's outer wall face that a tool swinging from a side hold meets it
MAX_SWING = 0.6  # rad a joint may turn in a lift's step that is not a straight move, once it has risen SIDE_LIFT_MIN
TIP_BELOW_TOP = 0.012  # m below an upside-down object's top where the closed fingertips push it over ...
TIP_START_GAP = 0.02  # ... starting this far from its near side ...
TIP_ANGLE = np.radians(80.0)  # ... and following that point as the object turns this far about its far edge ...
TIP_STEPS = 8  # ... in this many straight moves
FINGER_HALF_THICKNESS = 0.014  # m from the TCP to the face of the closed fingers that pushes
TIP_TURNS = (0.0, 20.0, -20.0, 40.0, -40.0)  # degrees from an upside-down object's short axis it may be pushed
TIP_LANDING_MARGIN = 0.01  # m kept between the side it falls onto and any other object ...
TIP_TRAVEL = 0.05  # ... and this much further out where there is room (it rolls, and stands up further out)
BOARD_APPROACH = 0.08  # m up a leaning board's slope from where the hand comes in to its raised end
BOARD_DRAW_RISE = 0.01  # m a board stood on its end is raised off the floor while it is drawn across ...
BOARD_WALL_GAP = 0.03  # ... to this far from the container's wall
BOARD_SET_GAP = 0.01  # m above the table that a standing board's end is lowered to ...
BOARD_LAY_PUSH = 0.05  # ... before the hand moves this far away from the container ...
BOARD_LAY_DROP = 0.3  # ... and down by this share of it, tipping the board over that way


def _where(onto: str | None, at: tuple[float, float] | None) -> str:
    return f"'{onto}'" if onto else f"the table at ({at[0]:.2f}, {at[1]:.2f})"


# ------------------------------------------------------------------------------------------------ pick and place
def pick_and_place(
    motion: MotionPlanner,
    name: str,
    grasp: np.ndarray,
    onto: str | None = None,
    at: tuple[float, float] | None = None,
    centred: bool = False,
    lift: float = 0.0,
    after: list[str] | None = None,
) -> None:
    """Queue the moves that take object `name` at the top-down `grasp` and set it down onto or into `onto` (at a
    free spot of it, or at its middle when `centred`), onto the table with the middle of its footprint at `at`, or
    (neither) lift it by `lift`. `after`: the objects still to go onto `onto` where it is a small top they share
    (`places.shared_place`), else None."""
    env = motion.env
    held_offset = grasp[:2] - centre(env, name)[:2]  # from the middle of the footprint to the TCP
    held_bottom = grasp[2] - object_bottom(env, name)  # TCP height above the object's bottom
    wide_as_fingers = snug(env, name, grasp)
    around = held_spread(env, name, grasp)  # how far the held object reaches from the TCP
    if onto is not None or at is not None:  # planned before the grasp, which holds the object as it is
        spot = None
        if onto is not None and not centred:
            spot = release_spot(motion, name, onto, grasp, held_bottom, after)
        place, above_place = (
            spot if spot is not None else place_pose(env, name, onto, at, grasp, held_bottom, held_offset)
        )
    qpos = motion.current_qpos()
    sideways = side_step_path(env, name, grasp)  # (beside, over): in under an overhang, else None
    above_grasp = above(env, grasp if sideways is None else sideways[0], APPROACH_HEIGHT, hanging=0.0)
    far = sideways is None and far_tool(env, name, grasp)  # a heavy tool at the edge of the arm's reach
    if far:
        above_grasp = reachable_above(motion, grasp, above_grasp)
    qpos = motion.reach_over_clear(qpos, above_grasp, grasp if sideways is None else sideways[0], name)
    if sideways is not None:
        qpos = motion.move(qpos, sideways[0], f"descend beside '{name}'")
        qpos = motion.move(qpos, sideways[1], f"move in over '{name}'")
        motion.hold(qpos, 0.0, STEP_SETTLE_STEPS)  # the pads go down millimetres from the object's edges
    if wide_as_fingers and sideways is None:  # the open pads pass it with millimetres to spare: settle above it
        qpos = motion.move(qpos, settle_pose(env, name, grasp), f"settle over '{name}'")
        motion.hold(qpos, 0.0, STEP_SETTLE_STEPS)
    qpos = motion.move(qpos, grasp, f"descend to '{name}'")
    motion.hold(qpos, 1.0, GRIPPER_STEPS)
    if far:  # drawn nearer the robot, just off the floor, where the arm can lift it
        qpos, grasp = draw_nearer(motion, qpos, grasp, name)
    if onto is None and at is None and sideways is None:
        motion.move(qpos, raised(grasp, lift), f"lift '{name}'")
        return
    lifted = above(env, grasp, LIFT_HEIGHT, hanging=held_bottom, held=name)
    if sideways is not None:  # back out from under the overhang, then up
        qpos = motion.move(qpos, raised(sideways[1], STEP_LIFT), f"raise '{name}' off the table")
        qpos = motion.move(qpos, raised(sideways[0], STEP_LIFT), f"move '{name}' out from under the overhang")
        if onto is None and at is None:
            motion.move(qpos, raised(sideways[0], STEP_LIFT + lift), f"lift '{name}'")
            return
        lifted = above(env, raised(sideways[0], STEP_LIFT), LIFT_HEIGHT, hanging=held_bottom, held=name)
    carry = high_carry(env, name, lifted, above_place, held_bottom, around, onto)
    qpos = motion.move(qpos, lifted if carry is None else carry[0], f"lift '{name}'")
    where = _where(onto, at)
    try:
        with motion.carrying(in_frame(world_points(env, name), grasp)):  # kept clear of a shelf's posts
            if carry is not None:  # over something tall on the way, at one height, then down over the place
                qpos = motion.move(qpos, carry[1], f"carry '{name}' high over {where}")
                qpos = motion.move(qpos, above_place, f"carry '{name}' over {where}", straight=False)
            else:
                qpos = carry_over(motion, qpos, lifted, above_place, f"carry '{name}' over {where}")
    except OracleFailure:  # too high above a shelf: in from the front, if there is a way
        way = front_place_way(motion, name, grasp, place)
        if way is None:
            raise
        front_place(motion, qpos, name, way, place, where)
        return
    qpos = motion.move(qpos, place, f"lower '{name}' onto {where}")
    motion.hold(qpos, 0.0, GRIPPER_STEPS)
    if wide_as_fingers:
        qpos = slide_off(motion, qpos, place, onto)
    motion.move(qpos, above_place, f"retreat from {where}")


def carry_over(
    motion: MotionPlanner, qpos: np.ndarray, lifted: np.ndarray, above_place: np.ndarray, what: str
) -> np.ndarray:
    """Queue the carry from the TCP pose `lifted` (the arm there, at posture `qpos`) to `above_place` on a joint
    path; where none keeps the held object clear of the fixtures and the place is higher, straight up to its height
    first and across from there. Returns the final joints."""
    try:
        return motion.move(qpos, above_place, what, straight=False)
    except OracleFailure:
        if above_place[2] <= lifted[2]:
            raise
    planned = motion.mark()
    risen = lifted.copy()
    risen[2] = above_place[2]
    try:
        qpos = motion.move(qpos, risen, f"{what}: rise to its height first")
        return motion.move(qpos, above_place, what, straight=False)
    except OracleFailure:
        motion.rewind(planned)
        raise


def release_spot(
    motion: MotionPlanner, name: str, onto: str, grasp: np.ndarray, held_bottom: float, after: list[str] | None
) -> Spot | None:
    """Where `name`, held by `grasp`, is set down on a free spot of `onto` that the arm reaches from above or the
    front (`placing_reach`), the first of: a spot shared with the objects `after` on a small top, head first into a
    pot, a free spot with the hand as grasped, and one with the hand turned about the vertical; None where none."""
    env = motion.env
    reachable = placing_reach(motion, name, grasp)
    return (
        (shared_place(env, name, onto, grasp, held_bottom, reachable, after) if after is not None else None)
        or head_first_place(env, name, onto, grasp, held_bottom, reachable)
        or free_place(env, name, onto, grasp, held_bottom, reachable)
        or turned_place(env, name, onto, grasp, held_bottom, reachable)
    )


def slide_off(motion: MotionPlanner, qpos: np.ndarray, place: np.ndarray, onto: str | None) -> np.ndarray:
    """After letting go of an object as wide as the open fingers (a can), move the hand SLIDE_OFF along the
    closing direction, towards the middle of `onto`, so one pad pushes the object a little and the other comes off
    it (lifted straight away, both pads would carry it up); the posture is kept where that cannot be planned."""
    closing = quat_to_matrix(place[3:])[:, 1]
    towards = (centre(motion.env, onto)[:2] - place[:2]) if onto is not None else -place[:2]
    sign = 1.0 if float(closing[:2] @ towards) >= 0.0 else -1.0
    try:
        return motion.move(
            qpos,
            shifted(place, sign * SLIDE_OFF * closing * np.array([1.0, 1.0, 0.0])),
            "slide the fingers off the object",
        )
    except OracleFailure:
        return qpos


# ------------------------------------------------------------------------------------------------ placing from the front
def front_place_way(motion: MotionPlanner, name: str, grasp: np.ndarray, place: np.ndarray) -> np.ndarray | None:
    """Where the TCP, holding `name` as grasped at `grasp`, waits in front of a place on a shelf that it cannot
    be lowered to from high above: `place` raised by FRONT_PLACE_RISE and moved horizontally towards the robot
    until the hand and the object are clear of every fixture's footprint. None without fixtures, or where the
    hand would hit one on the way."""
    if not motion.fixture_names:
        return None
    held = world_points(motion.env, name) - grasp[:3]
    toward = -place[:2] / np.linalg.norm(place[:2])
    return moved_out(raised(place, FRONT_PLACE_RISE), toward, fixture_boxes(motion.env), held)


def placing_reach(motion: MotionPlanner, name: str, grasp: np.ndarray) -> Reachable:
    """A test for the place samplers: whether the arm holding `name` (grasped at `grasp`) reaches the pose over a
    place and lowers it straight from there, or else comes in horizontally from the front (`front_place_way`)."""

    def reachable(over: np.ndarray, place: np.ndarray) -> bool:
        if motion.can_lower(over, place):
            return True
        way = front_place_way(motion, name, grasp, place)
        if way is None:
            return False
        status, postures = motion.ik(way, motion.current_qpos(), serves=any_posture)
        if status != "Success":
            return False
        start = motion.current_qpos()
        start[:7] = postures[0][:7]
        return motion.straight_chain(start, [raised(place, FRONT_PLACE_RISE), place]) is not None

    return reachable


def front_place(
    motion: MotionPlanner, qpos: np.ndarray, name: str, way: np.ndarray, place: np.ndarray, where: str
) -> None:
    """Set the held object down on a high shelf from the front: carry it to `way` (see `front_place_way`), slide it
    in horizontally over `place`, lower it, let go, and take the hand back up a little and out."""
    qpos = motion.move_for_chain(
        qpos, way, [raised(place, FRONT_PLACE_RISE), place], f"carry '{name}' in front of {where}"
    )
    qpos = motion.move_straight(qpos, raised(place, FRONT_PLACE_RISE), f"slide '{name}' in over {where}")
    qpos = motion.move_straight(qpos, place, f"lower '{name}' onto {where}")
    motion.hold(qpos, 0.0, GRIPPER_STEPS)
    try:  # the object is let go: taking the hand out is a courtesy, not a must
        qpos = motion.move_straight(qpos, raised(place, FRONT_PLACE_LEAVE), f"raise the hand off '{name}'")
        motion.move_straight(qpos, raised(way, FRONT_PLACE_LEAVE - FRONT_PLACE_RISE), f"retreat from {where}")
    except OracleFailure:
        pass


# ------------------------------------------------------------------------------------------------ off a shelf level
def front_pick_and_place(
    motion: MotionPlanner,
    name: str,
    onto: str | None = None,
    at: tuple[float, float] | None = None,
    centred: bool = False,
    lift: float = 0.0,
) -> None:
    """Take object `name` off a shelf level under another one (`pick_and_place`'s destinations): the hand comes in
    leaning out of the shelf (`side_grasps.front_grasps`), grasps, lifts the object off the level a little and
    pulls it straight out, then carries it on. Grasps are tried in turn until one can be planned."""
    grasps = front_grasps(motion.env, name)
    if not grasps:
        raise OracleFailure(
            f"'{name}' is under a shelf level and no hand leaning in from the open side clears the shelf"
        )
    planned, failure = motion.mark(), None
    for grasp in grasps:
        try:
            _front_attempt(motion, name, grasp, onto, at, centred, lift)
            return
        except OracleFailure as error:
            failure = error
            motion.rewind(planned)
            motion.gripper = 0.0
    raise failure


def _front_attempt(
    motion: MotionPlanner,
    name: str,
    grasp: FrontGrasp,
    onto: str | None,
    at: tuple[float, float] | None,
    centred: bool,
    lift: float,
) -> None:
    """The moves of `front_pick_and_place` with one front grasp."""
    env = motion.env
    outs = ways_out(env, name, grasp)
    if not outs:
        raise OracleFailure(f"cannot pull '{name}' out of the shelf: the hand would hit it")
    held_offset = grasp.pose[:2] - centre(env, name)[:2]
    held_bottom = grasp.pose[2] - object_bottom(env, name)
    if onto is not None or at is not None:
        spread = onto is not None and not centred
        spot = free_place(env, name, onto, grasp.pose, held_bottom, motion.can_lower) if spread else None
        if onto is None:  # on the table: the object turned about the vertical where the hand cannot lower it as held
            # (reached as the carry reaches it: inverse kinematics from many starts, then straight down)
            reach = partial(motion.can_lower, starts=IK_RETRIES)
            spot = turned_table_place(env, name, at, grasp.pose, held_bottom, held_offset, reach)
        place, above_place = (
            spot if spot is not None else place_pose(env, name, onto, at, grasp.pose, held_bottom, held_offset)
        )
    qpos, (towards, onto_grasp, off_level, pull), out = reach_in_and_out(motion, name, grasp, outs)
    qpos = motion.queue(motion.queue(qpos, towards), onto_grasp)
    motion.hold(qpos, 1.0, GRIPPER_STEPS)
    qpos = motion.queue(motion.queue(qpos, off_level), pull)
    if onto is None and at is None:
        motion.move(qpos, raised(out, lift), f"lift '{name}'")
        return
    qpos = motion.move(qpos, raised(out, LIFT_HEIGHT), f"lift '{name}'")
    where = _where(onto, at)
    # into a posture from which the arm lowers it straight (held by the rim, it swings on a sampled path)
    qpos = motion.move_for_chain(qpos, above_place, [place], f"carry '{name}' over {where}")
    qpos = motion.move_straight(qpos, place, f"lower '{name}' onto {where}")
    motion.hold(qpos, 0.0, GRIPPER_STEPS)
    motion.move(qpos, above_place, f"retreat from {where}")


def reach_in_and_out(
    motion: MotionPlanner, name: str, grasp: FrontGrasp, outs: list[np.ndarray]
) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """Queue the move to the front of the shelf (`grasp.entry`) into a posture from which the hand goes in, onto
    `grasp`, off the level and out to the first of `outs` (see `ways_out`) that it reaches, all in straight lines: a
    sampled path in the shelf sweeps the hand into what stands there and swings the held object. Returns the
    joints at the entry, the four straight paths (not queued) and the pose out."""
    planned, start = motion.mark(), motion.current_qpos()
    for out in outs:
        chain = [grasp.approach, grasp.pose, raised(grasp.pose, FRONT_LIFT), out]
        qpos = motion.move_for_chain(start, grasp.entry, chain, f"reach in front of '{name}'")
        paths = motion.straight_chain(qpos, chain)
        if paths is not None:
            return qpos, paths, out
        motion.rewind(planned)
    raise OracleFailure(f"cannot reach in to '{name}' and pull it out of the shelf in straight lines")


# ------------------------------------------------------------------------------------------------ heavy tools far away
def far_tool(env: RoboLabEnv, name: str, grasp: np.ndarray) -> bool:
    """Whether object `name` is a heavy or long tool and `grasp` (a TCP pose, robot frame) is beyond TOOL_REACH from
    the robot's base (horizontally): it can be grasped there, but the arm can neither go APPROACH_HEIGHT above it
    nor lift it straight out (held off its centre of mass, it turns in the pads)."""
    if float(np.linalg.norm(grasp[:2])) <= TOOL_REACH:
        return False
    return is_heavy(env, name) or is_tool(env, name, world_points(env, name))


def reachable_above(motion: MotionPlanner, grasp: np.ndarray, over: np.ndarray) -> np.ndarray:
    """The pose a far tool's grasp is come down to from: `over` where the arm reaches it (inverse kinematics),
    else the highest pose down to APPROACH_LOWEST over the grasp that it reaches, over the grasp or drawn back
    towards the robot by one of APPROACH_BACKS; `over` where none is reached (the planner then says why)."""
    toward = -grasp[:2] / np.linalg.norm(grasp[:2])
    for height in np.arange(over[2], grasp[2] + APPROACH_LOWEST - 1e-6, -APPROACH_STEP):
        for back in APPROACH_BACKS:
            pose = grasp.copy()
            pose[:2] += toward * back
            pose[2] = height
            status, _ = motion.ik(pose, motion.current_qpos(), IK_RETRIES, serves=any_posture)
            if status == "Success":
                return pose
    return over


def draw_nearer(motion: MotionPlanner, qpos: np.ndarray, grasp: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Queue a straight move of the hand holding a far tool (grasped at `grasp`) towards the robot, to TOOL_REACH
    (at most DRAW_MAX) and DRAW_RISE up; returns the final joints and the TCP pose there (`qpos` and `grasp` where
    that move cannot be planned)."""
    distance = float(np.linalg.norm(grasp[:2]))
    nearer = grasp.copy()
    nearer[:2] *= max(TOOL_REACH, distance - DRAW_MAX) / distance
    nearer[2] += DRAW_RISE
    planned = motion.mark()
    try:
        return motion.move(qpos, nearer, f"draw '{name}' nearer"), nearer
    except OracleFailure:
        motion.rewind(planned)
        return qpos, grasp


# ------------------------------------------------------------------------------------------------ side holds
class LiftFailure(OracleFailure):
    """A side hold's plan failed after the hand reached the handle: in the lift, the carry or the set-down."""


def side_hold_pick_and_place(
    motion: MotionPlanner,
    name: str,
    grips: list[tuple[np.ndarray, np.ndarray]],
    tried: list[np.ndarray],
    onto: str | None = None,
    at: tuple[float, float] | None = None,
) -> None:
    """Take long tool `name` by its handle with the first of `grips` (side holds, `side_grasps.side_grips`) that has
    a motion plan, starting after the holds in `tried` (those earlier plans used; the one used is added), and set
    it down onto `onto` or the table at `at`; OracleFailure where none has a plan."""
    first = min(len(tried), len(grips) - 1)
    for grasp, approach in grips[first:] + grips[:first]:  # the next hold each time the job is planned again
        for hand in (grasp, rolled(grasp)):  # the wrist turns with the swinging tool: one way may be at its limit
            planned = motion.mark()
            try:
                _side_hold_moves(motion, name, hand, approach, onto, at)
            except LiftFailure:
                motion.rewind(planned)
                continue  # the hand half-turned may have the room to turn with the tool
            except OracleFailure:
                motion.rewind(planned)
                break  # the hand half-turned reaches the handle no better
            tried.append(grasp)
            return
    tried.append(grips[first][0])
    raise OracleFailure(f"cannot hold '{name}' by its handle from the side: no motion plan for any hold")


def _side_hold_moves(
    motion: MotionPlanner,
    name: str,
    grasp: np.ndarray,
    approach: np.ndarray,
    onto: str | None,
    at: tuple[float, float] | None,
) -> None:
    """Queue the moves of `side_hold_pick_and_place` with the object held at TCP pose `grasp`, the hand coming in
    along `approach`: down beside the handle from the height the tool will be lifted to (so that the arm is posed
    to lift it straight back up), in, closed, lifted in straight steps until the tool hanging straight down from the
    grip would clear its container, carried level, lowered, let go, and backed out the way it came."""
    env = motion.env
    held_bottom = grasp[2] - object_bottom(env, name)
    held_offset = grasp[:2] - centre(env, name)[:2]
    place, _ = place_pose(env, name, onto, at, grasp, held_bottom, held_offset)
    container = container_below(env, name)
    rim = float(world_points(env, container)[:, 2].max()) if container is not None else 0.0
    lifted = grasp.copy()
    hanging = float(np.linalg.norm(world_points(env, name) - grasp[:3], axis=1).max())  # should it swing down
    lifted[2] = max(grasp[2] + SIDE_LIFT_MIN, rim + SIDE_LIFT_CLEARANCE + hanging)
    qpos = motion.current_qpos()
    starts = _side_hold_starts(env, name, grasp, approach)
    for start in starts:
        high = start.copy()
        high[2] = lifted[2]
        planned = motion.mark()
        try:  # down from the height of the lift, so that the arm is posed to lift the tool straight back up
            qpos = motion.move(qpos, high, f"reach above beside the handle of '{name}'", straight=False)
            qpos, _ = _rise(motion, qpos, high, start[2], f"reach beside the handle of '{name}'")
            break
        except OracleFailure:
            motion.rewind(planned)
        try:
            qpos = motion.move(qpos, start, f"reach beside the handle of '{name}'", straight=False)
            break
        except OracleFailure:
            if start is starts[-1]:
                raise
    qpos = motion.move_straight(qpos, grasp, f"move in around the handle of '{name}'")
    motion.hold(qpos, 1.0, GRIPPER_STEPS)
    try:
        _lift_and_set_down(motion, qpos, name, grasp, approach, lifted[2], place, container, at, onto)
    except OracleFailure as failure:
        raise LiftFailure(str(failure)) from failure


def _side_hold_starts(env: RoboLabEnv, name: str, grasp: np.ndarray, approach: np.ndarray) -> list[np.ndarray]:
    """The TCP poses a side hold at `grasp` may start in from, each with the hand as it holds, in the order they are
    tried: level across the handle, SIDE_APPROACHES back along `approach`; then along the handle from
    SIDE_SLIDE_PAST beyond its free end, the open fingers sliding on over it (where the arm cannot point across
    the handle from further out, beside a wall it lies against)."""
    starts = []
    for distance in SIDE_APPROACHES:
        start = grasp.copy()
        start[:3] -= approach * distance
        starts.append(start)
    handle = handle_part(env, name)
    if handle is not None:
        end, direction, _, _ = handle
        start = grasp.copy()
        start[:3] -= direction * (float((grasp[:3] - end) @ direction) + SIDE_SLIDE_PAST)
        starts.append(start)
    return starts


def _lift_and_set_down(
    motion: MotionPlanner,
    qpos: np.ndarray,
    name: str,
    grasp: np.ndarray,
    approach: np.ndarray,
    height: float,
    place: np.ndarray,
    container: str | None,
    at: tuple[float, float] | None,
    onto: str | None,
) -> None:
    """Queue the rest of a side hold's moves once the hand has closed on the handle at TCP pose `grasp`: the lift
    to `height` (`_swing_lift`), the carry, the set-down at `place` (a hanging tool laid over onto the table at
    `at`), the release and the way back out along `approach`."""
    env = motion.env
    qpos, lifted, hanging = _swing_lift(motion, qpos, grasp, height, name, container, f"lift '{name}' by its handle")
    way = lifted.copy()
    way[:2] = place[:2]
    lay = None
    if onto is None and hanging is not None:  # set down on its lower end beside `at`, laid over onto `at`
        lay = np.array([-approach[1], approach[0], 0.0])  # level, in the plane it swung in
        if container is not None and (np.asarray(at) - centre(env, container)[:2]) @ lay[:2] < 0:
            lay = -lay  # laid down away from the container
        bottom = hanging[hanging[:, 2] < hanging[:, 2].min() + LAY_BASE]
        pivot = bottom[np.argmax(bottom @ lay)]  # the edge of its lower end that it is turned over about
        length = float(np.ptp(world_points(env, name) @ lay))
        way[:2] = np.asarray(at) - lay[:2] * length / 2 - pivot[:2]
        tilted = np.cos(LAY_ANGLE) * np.array([0.0, 0.0, 1.0]) - np.sin(LAY_ANGLE) * lay
    try:
        qpos = motion.move_straight(qpos, way, f"carry '{name}' by its handle")
    except OracleFailure:
        qpos = motion.move(qpos, way, f"carry '{name}' by its handle")
    if lay is None:
        qpos, place = _rise(motion, qpos, way, place[2], f"lower '{name}'")
    else:
        qpos, low = _rise(motion, qpos, way, LAY_GAP - pivot[2], f"lower '{name}' onto its end")
        for place in tip_poses(low, low[:3] + pivot - [0.0, 0.0, LAY_GAP], tilted):
            qpos = motion.move_straight(qpos, place, f"lay '{name}' down")
    motion.hold(qpos, 0.0, GRIPPER_STEPS)
    back = place.copy()
    back[:3] -= approach * SIDE_BACK_OUT
    try:
        qpos = motion.move_straight(qpos, back, f"back out from '{name}'")
    except OracleFailure:
        pass
    up = back.copy()
    up[2] += SIDE_RETREAT
    try:
        motion.move(qpos, up, f"retreat from '{name}'")
    except OracleFailure:
        pass


def swing_angle(
    height: float, start: float, reach: float, slope: float, depth: float, wall: float, rim: float
) -> float:
    """The angle (rad) below the horizontal of a tool hanging by its handle from a grip at `height` that was at
    `start` when the tool's far end (`reach` from the grip, `slope` rad below it, its lowest point `depth` lower)
    rested on its container's floor: the far end slides along the floor under the rising grip, stopped `wall` out
    (horizontally) by the container's near wall until its lowest point is higher than `rim`; past the rim the tool
    hangs straight down."""
    floor = start - reach * np.sin(slope)
    natural = float(np.arcsin(np.clip((height - floor) / reach, -1.0, 1.0)))
    held_back = float(np.arccos(np.clip(wall / reach, -1.0, 1.0)))
    angle = max(slope, min(natural, held_back))
    if height - reach * np.sin(angle) - depth > rim:
        return np.pi / 2
    return angle


def _swing_lift(
    motion: MotionPlanner,
    qpos: np.ndarray,
    grasp: np.ndarray,
    height: float,
    name: str,
    container: str | None,
    what: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Queue the lift of a tool held from the side at TCP pose `grasp` to `height` in steps of RISE_STEP, the hand
    turning about its approach axis as the tool swings down to hang from the grip (`swing_angle`), so that the
    pads keep closing across the handle; returns the final joints and TCP pose, and where the tool's surface
    points are from the TCP where it ends hanging straight down (None where it does not)."""
    env = motion.env
    points = world_points(env, name)
    rotation = quat_to_matrix(grasp[3:])
    approach = rotation[:, 2]
    far = points[np.argmax(np.linalg.norm(points - grasp[:3], axis=1))] - grasp[:3]
    far -= (far @ approach) * approach  # in the plane the tool swings in
    reach = float(np.linalg.norm(far))
    outward = np.array([far[0], far[1], 0.0]) / max(float(np.linalg.norm(far[:2])), 1e-9)
    slope = float(np.arcsin(np.clip(-far[2] / reach, -1.0, 1.0)))
    end = points[np.linalg.norm(points - grasp[:3], axis=1) > reach - SWING_END]
    depth = float(far[2] + grasp[2] - end[:, 2].min())  # the far end's lowest point under its farthest one
    axis = np.cross(outward, np.array([0.0, 0.0, -1.0]))  # turning `outward` towards straight down
    wall, rim = 0.0, -np.inf
    if container is not None:
        box = world_points(env, container)
        wall = float(((box[:, :2] - grasp[:2]) @ outward[:2]).min()) + SWING_WALL
        rim = float(box[:, 2].max()) + SIDE_LIFT_CLEARANCE
    step = previous = grasp.copy()
    while height - step[2] > 1e-6:
        step = step.copy()
        step[2] += min(RISE_STEP, height - step[2])
        turn = swing_angle(step[2], grasp[2], reach, slope, depth, wall, rim) - slope
        if height - step[2] < 1e-6:  # lifted as high as the tool hanging straight down needs
            turn = np.pi / 2 - slope
        step[3:] = matrix_to_quaternion(rotation_about(axis, turn) @ rotation)
        try:
            qpos = motion.move_straight(qpos, step, what)
        except OracleFailure:
            if turn < np.pi / 2 - slope - 1e-6 or step[2] - grasp[2] < SIDE_LIFT_MIN + RISE_STEP:
                raise
            step = previous  # hanging, and high enough: no swing of the arm to go higher
            break
        previous = step
    turn = swing_angle(step[2], grasp[2], reach, slope, depth, wall, rim) - slope
    if turn < np.pi / 2 - slope - 1e-6 and height - step[2] > 1e-6:
        return qpos, step, None
    turn = np.pi / 2 - slope
    return qpos, step, (points - grasp[:3]) @ rotation_about(axis, turn).T


def _rise(
    motion: MotionPlanner, qpos: np.ndarray, pose: np.ndarray, height: float, what: str
) -> tuple[np.ndarray, np.ndarray]:
    """Queue a move of the TCP from `pose` straight up or down to `height`, in steps of RISE_STEP (each a straight
    move where one is found, else any move to it; a lift stops short where it has risen SIDE_LIFT_MIN and the next
    step would swing a joint by more than MAX_SWING); returns the final joints and TCP pose."""
    step, sign = pose.copy(), 1.0 if height >= pose[2] else -1.0
    while sign * (height - step[2]) > 1e-6:
        previous, step = step, step.copy()
        step[2] = step[2] + sign * min(RISE_STEP, sign * (height - step[2]))
        try:
            qpos = motion.move_straight(qpos, step, what)
        except OracleFailure:
            planned = motion.mark()
            moved = motion.move(qpos, step, what)
            if sign > 0 and previous[2] - pose[2] >= SIDE_LIFT_MIN and np.abs(moved[:7] - qpos[:7]).max() > MAX_SWING:
                motion.rewind(planned)  # high enough: no swing of the arm to go higher
                return qpos, previous
            qpos = moved
    return qpos, step


# ------------------------------------------------------------------------------------------------ standing up
def stand_upright(motion: MotionPlanner, name: str) -> None:
    """Stand a lying object up. A lying container is held by the top of its rim (one finger inside) and tipped
    up about the lowest point of its base, which stays on the table; another object is first held by the narrow
    part at its top end and tipped the same way, else grasped from above across its body, lifted, turned so its up
    axis points up, and set down where it lay."""
    env = motion.env
    up = env.eval_context.up_axis(name)[0].cpu().numpy().astype(np.float64)
    flat = np.array([up[0], up[1], 0.0])
    if np.linalg.norm(flat) < 1e-3:
        raise OracleFailure(f"'{name}' is upside down: turning it over is not supported")
    flat /= np.linalg.norm(flat)
    planned = motion.mark()
    if env.eval_context.entries[name].is_container:
        grasp = rim_grasp(env, name, up)
        # the hand may hold the rim either way up; near joint limits only one of them can be planned; turned
        # about the vertical where the hand would meet a neighbour on the line of the container's axis
        attempts = [
            lambda g=g: pivot_upright(motion, name, up, g)
            for turned in turned_rim_grasps(env, name, grasp)
            for g in (turned, rolled(turned))
        ]
    else:
        closing = np.cross([0.0, 0.0, 1.0], flat)  # across the body, horizontal: the object turns about this axis
        attempts = [lambda c=c: lift_and_turn_upright(motion, name, up, c) for c in (closing, -closing)]
        end = end_grasp(env, name, up)  # first: held by the narrow part at its top end and tipped up about its base
        if end is not None:
            attempts[:0] = [
                lambda g=g: pivot_upright(motion, name, up, g, backing=np.array([0.0, 0.0, 1.0]))
                for g in (end, rolled(end))
            ]
    for attempt, plan in enumerate(attempts):
        try:
            plan()
            return
        except OracleFailure:
            motion.rewind(planned)
            if attempt == len(attempts) - 1:
                raise


def pivot_upright(
    motion: MotionPlanner, name: str, up: np.ndarray, grasp: np.ndarray, backing: np.ndarray | None = None
) -> None:
    """Hold a lying object by `grasp` (a container's rim, reached straight through its opening; or any grasp
    reached straight along `backing`, the direction the hand backs away from it) and tip it up about the lowest
    point of its base, which stays on the table, then let go and lift the hand. The arm posture at the grasp is
    chosen so that the whole tipping motion is one chain of straight moves."""
    env = motion.env
    pivot = tip_pivot(world_points(env, name), up)  # where the base touches the table: it stays there
    tipping = tip_poses(grasp, pivot, up)
    qpos = motion.current_qpos()
    outside = shifted(grasp, (up if backing is None else backing) * RIM_APPROACH)
    high = raised(outside, APPROACH_HEIGHT) if backing is None else above(env, outside, APPROACH_HEIGHT, 0.0)
    at_grasp, tip_paths, back_out = tip_posture(
        motion, grasp, tipping, [outside, high], f"the rim of '{name}'", f"tip '{name}' up about its base"
    )
    # come in the way the hand would back out: down beside the opening, then straight in
    above_outside = at_grasp.copy()
    above_outside[:7] = back_out[-1][-1]
    result = motion.plan_to_joints([above_outside], qpos)
    if result["status"] != "Success":
        raise OracleFailure(f"cannot reach the opening of '{name}': no motion plan ({result['status']})")
    motion.queue(qpos, result["position"])
    outside_posture = motion.queue(above_outside, back_out[1][::-1])
    if backing is None:  # level into an opening: a lagging arm that cut the corner would come down on the rim
        motion.hold(outside_posture, 0.0, STEP_SETTLE_STEPS)
    motion.queue(outside_posture, np.concatenate([back_out[0][::-1][1:], [at_grasp[:7]]]))
    motion.hold(at_grasp, 1.0, GRIPPER_STEPS)
    for path in tip_paths:
        motion.queue(at_grasp, path)
    final = at_grasp.copy()
    final[:7] = tip_paths[-1][-1]
    motion.hold(final, 1.0, PIVOT_HOLD_STEPS)  # let go only once the object has turned all the way
    motion.hold(final, 0.0, GRIPPER_STEPS)
    try:  # the object stands and is let go: lifting the hand away is a courtesy, not a must
        motion.move(final, raised(tipping[-1], APPROACH_HEIGHT), f"lift the hand out of '{name}'")
    except OracleFailure:
        pass


def tip_poses(grasp: np.ndarray, pivot: np.ndarray, up: np.ndarray) -> list[np.ndarray]:
    """The TCP poses, PIVOT_STEPS of them, of a hand holding an object at `grasp` while the object turns about
    `pivot` until its axis `up` points straight up."""
    axis = np.cross(up, [0.0, 0.0, 1.0])
    angle = np.arccos(np.clip(up[2], -1.0, 1.0))
    hand = quat_to_matrix(grasp[3:])
    poses = []
    for step in range(1, PIVOT_STEPS + 1):
        turn = rotation_about(axis, angle * step / PIVOT_STEPS)
        poses.append(np.concatenate([pivot + turn @ (grasp[:3] - pivot), matrix_to_quaternion(turn @ hand)]))
    return poses


def lift_out_standing(motion: MotionPlanner, name: str, board: Board, at: tuple[float, float]) -> None:
    """Take board `name` out of the container it leans in and lay it on the table with its end at `at`: stood up
    on its low end (`stand_on_end`), drawn across the floor towards the wall on the side of `at`, lifted until its
    end clears the rim, carried level (turned as `places.standing_spot` turns it there), lowered until its end is
    just above the table, tipped away from the container by the hand and let go, so that it falls flat outside."""
    env = motion.env
    qpos, standing, hanging = stand_on_end(motion, name, board)
    spot = standing_spot(env, name, board, [], at=np.asarray(at))
    container = container_below(env, name)
    box = world_points(env, container)
    out = np.asarray(at) - standing[:2]
    out /= max(float(np.linalg.norm(out)), 1e-9)
    room = float((box[:, :2] @ out).max() - standing[:2] @ out) - board.thickness / 2 - BOARD_WALL_GAP
    drawn = raised(standing, BOARD_DRAW_RISE)
    drawn[:2] += out * max(room, 0.0)
    qpos = motion.move_straight(qpos, drawn, f"draw '{name}' across to the wall")
    qpos, lifted = _rise(motion, qpos, drawn, float(box[:, 2].max()) + SIDE_LIFT_CLEARANCE + hanging, f"lift '{name}'")
    turn = rotation_about(np.array([0.0, 0.0, 1.0]), spot.turn)
    way = np.concatenate([[at[0], at[1], lifted[2]], matrix_to_quaternion(turn @ quat_to_matrix(lifted[3:]))])
    try:
        qpos = motion.move_straight(qpos, way, f"carry '{name}' standing")
    except OracleFailure:
        qpos = motion.move(qpos, way, f"carry '{name}' standing")
    qpos, low = _rise(motion, qpos, way, hanging + BOARD_SET_GAP, f"lower '{name}' onto its end")
    tipped = shifted(low, np.array([spot.lay[0], spot.lay[1], -BOARD_LAY_DROP]) * BOARD_LAY_PUSH)
    qpos = motion.move_straight(qpos, tipped, f"tip '{name}' away from '{container}'")
    motion.hold(qpos, 0.0, GRIPPER_STEPS)
    try:  # the board is let go: moving the hand away is a courtesy, not a must
        motion.move(qpos, raised(shifted(tipped, board.up * BOARD_APPROACH), APPROACH_HEIGHT), f"retreat from '{name}'")
    except OracleFailure:
        pass


def stand_on_end(motion: MotionPlanner, name: str, board: Board) -> tuple[np.ndarray, np.ndarray, float]:
    """Queue the moves that take leaning board `name` at its raised end (`board_end_grasp`, reached straight down
    its slope) and tip it up about the lowest point of its low end until it stands on it, held (hanging from the
    pads, it cannot turn in them). Returns the joints and the TCP pose at the end, and how far below the TCP the
    board's end is. The arm posture at the grasp is chosen so that the whole tip is one chain of straight moves."""
    env = motion.env
    grasp = board_end_grasp(env, name, board)
    pivot = tip_pivot(world_points(env, name), board.up)
    tipping = tip_poses(grasp, pivot, board.up)
    qpos = motion.current_qpos()
    approach = shifted(grasp, board.up * BOARD_APPROACH)
    at_grasp, tip_paths, way_in = tip_posture(
        motion, grasp, tipping, [approach], f"the raised end of '{name}'", f"stand '{name}' up on its end"
    )
    before = at_grasp.copy()
    before[:7] = way_in[-1][-1]
    result = motion.plan_to_joints([before], qpos)
    if result["status"] != "Success":
        raise OracleFailure(f"cannot reach the raised end of '{name}': no motion plan ({result['status']})")
    motion.queue(qpos, result["position"])
    motion.queue(before, np.concatenate([way_in[0][::-1][1:], [at_grasp[:7]]]))
    motion.hold(at_grasp, 1.0, GRIPPER_STEPS)
    for path in tip_paths:
        motion.queue(at_grasp, path)
    qpos = at_grasp.copy()
    qpos[:7] = tip_paths[-1][-1]
    motion.hold(qpos, 1.0, PIVOT_HOLD_STEPS)
    return qpos, tipping[-1], float(tipping[-1][2] - pivot[2])


def tip_pivot(points: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The point an object of surface `points` turns about when tipped up onto its end lowest along `up`: the
    lowest point of that end (within BASE_BAND of it along `up`)."""
    along = points @ up
    end = points[along < along.min() + BASE_BAND]
    return end[end[:, 2].argmin()]


def tip_posture(
    motion: MotionPlanner, grasp: np.ndarray, tipping: list[np.ndarray], way_out: list[np.ndarray], part: str, tip: str
) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """The arm's joints at TCP pose `grasp` from which both the tip through the TCP poses `tipping` and the way out
    through `way_out` are chains of straight moves (of the postures inverse kinematics finds, the nearest the current
    joints first), with the joint paths of both chains; OracleFailure naming `part` (what is grasped) where the grasp
    is out of reach, and `tip` where no posture allows both chains."""
    qpos = motion.current_qpos()
    status, postures = motion.ik(grasp, qpos, IK_RETRIES)
    if status != "Success":
        raise OracleFailure(f"cannot reach {part}: {status}")
    for posture in sorted(postures, key=lambda p: np.abs(p[:7] - qpos[:7]).sum()):
        at_grasp = qpos.copy()
        at_grasp[:7] = posture[:7]
        tip_paths = motion.straight_chain(at_grasp, tipping)
        if tip_paths is None:
            continue
        way_paths = motion.straight_chain(at_grasp, way_out)
        if way_paths is not None:
            return at_grasp, tip_paths, way_paths
    raise OracleFailure(f"cannot {tip}: no arm posture allows the straight moves")


def lift_and_turn_upright(motion: MotionPlanner, name: str, up: np.ndarray, closing: np.ndarray) -> None:
    """Grasp `name` from above with the fingers closing along `closing`, lift it, tip its up axis to world z
    with the hand turned to point away from the robot, set it down where it lay and back off."""
    env = motion.env
    grasp = grasp_pose(env, name, closing=closing, keep_sign=True)
    qpos = motion.current_qpos()
    qpos = motion.move(qpos, raised(grasp, APPROACH_HEIGHT), f"reach above '{name}'", straight=False)
    qpos = motion.move(qpos, grasp, f"descend to '{name}'")
    motion.hold(qpos, 1.0, GRIPPER_STEPS)
    qpos = motion.move(qpos, raised(grasp, LIFT_HEIGHT), f"lift '{name}'")
    tip = rotation_between(up, np.array([0.0, 0.0, 1.0]))
    hand_axis = tip @ quat_to_matrix(grasp[3:])[:, 2]  # the fingers' direction after tipping
    outward = np.array([grasp[0], grasp[1], 0.0]) / np.linalg.norm(grasp[:2])
    turn = rotation_between(np.array([hand_axis[0], hand_axis[1], 0.0]), outward)
    final_rotation = turn @ tip @ quat_to_matrix(grasp[3:])
    object_points = world_points(env, name)
    lying_centre = (object_points.max(axis=0) + object_points.min(axis=0)) / 2
    object_in_hand = (object_points - grasp[:3]) @ (turn @ tip).T  # object points relative to the TCP, turned
    middle = (object_in_hand.max(axis=0) + object_in_hand.min(axis=0)) / 2
    target_xy = lying_centre[:2] - middle[:2]  # the object stands where it lay
    z = RELEASE_CLEARANCE - object_in_hand[:, 2].min()
    stand = np.concatenate([[target_xy[0], target_xy[1], z], matrix_to_quaternion(final_rotation)])
    qpos = motion.move(qpos, raised(stand, APPROACH_HEIGHT), f"turn '{name}' upright", straight=False)
    qpos = motion.move(qpos, stand, f"set '{name}' down upright")
    motion.hold(qpos, 0.0, GRIPPER_STEPS)
    back = stand.copy()
    back[:3] += -final_rotation[:, 2] * BACK_OFF + np.array([0.0, 0.0, BACK_OFF])  # back along the fingers and up
    try:  # the object stands and is let go: moving the hand away is a courtesy, not a must
        qpos = motion.move(qpos, back, f"back off from '{name}'")
        motion.move(qpos, raised(back, APPROACH_HEIGHT), f"raise the hand above '{name}'")
    except OracleFailure:
        pass


# ------------------------------------------------------------------------------------------------ turning over
def upside_down(env: RoboLabEnv, name: str) -> bool:
    """Whether object `name` stands on its top: its up axis points down, further than a lying object's."""
    return tilt(env, name) > UPSIDE_DOWN_TILT


def tip_directions(env: RoboLabEnv, name: str, travel: float = TIP_TRAVEL) -> list[np.ndarray]:
    """The horizontal directions in which upside-down object `name` can be pushed over onto a free stretch of the
    table: its footprint's short axis either way and those turned from it by TIP_TURNS (a mug then falls with its
    handle beside it, not under it), the least turned first and of those the one with more room; only those where
    the stretch it falls onto (its height and `travel` more beyond its far side, as wide as it is) keeps
    TIP_LANDING_MARGIN from every other object."""
    points = world_points(env, name)
    flat = points[:, :2] - points[:, :2].mean(axis=0)
    short = np.linalg.svd(flat, full_matrices=False)[2][1]  # the footprint's short axis
    middle = points[:, :2].mean(axis=0)
    height = float(np.ptp(points[:, 2]))
    others = [world_points(env, other) for other in env.objects if other != name]
    others = np.concatenate([other[other[:, 2] < height + TIP_LANDING_MARGIN, :2] for other in others]) - middle
    found = []
    for turn in TIP_TURNS:
        for sign in (1.0, -1.0):
            angle = np.radians(turn) + (0.0 if sign > 0 else np.pi)
            direction = np.array(
                [
                    short[0] * np.cos(angle) - short[1] * np.sin(angle),
                    short[0] * np.sin(angle) + short[1] * np.cos(angle),
                ]
            )
            across = np.array([-direction[1], direction[0]])
            beyond = others @ direction - float((flat @ direction).max())  # from the far side, along the push
            sideways = np.abs(others @ across) - float(np.abs(flat @ across).max())  # outside its width
            gap = np.maximum(np.maximum(beyond - height - travel, -beyond), sideways)  # outside the side it falls onto
            clearance = float(gap.min(initial=np.inf))
            if clearance >= TIP_LANDING_MARGIN:
                found.append((abs(turn), -clearance, np.array([direction[0], direction[1], 0.0])))
    return [direction for *_, direction in sorted(found, key=lambda entry: entry[:2])]


def tip_onto_side(motion: MotionPlanner, name: str) -> None:
    """Push upside-down object `name` over onto its side: the closed fingers, pointing down, come down beside it
    and push its near side just below its top (TIP_BELOW_TOP) along the arc that point takes as the object turns
    about the far edge of its footprint (TIP_STEPS straight moves, to TIP_ANGLE, past its balance); then the hand
    rises. The first of `tip_directions` with a motion plan (those with room for it to roll and stand up first);
    OracleFailure where none has one."""
    env = motion.env
    directions = tip_directions(env, name) or tip_directions(env, name, travel=0.0)
    if not directions:
        raise OracleFailure(f"'{name}' is upside down and there is no free room beside it to tip it onto its side")
    points = world_points(env, name)
    middle = centre(env, name)
    top, bottom = float(points[:, 2].max()), float(points[:, 2].min())
    failure = None
    for direction in directions:
        along = (points[:, :2] - middle[:2]) @ direction[:2]
        orientation = down_quaternion(np.array([-direction[1], direction[0], 0.0]))  # fingers' width along the push
        contact = np.concatenate([middle[:2] + direction[:2] * float(along.min()), [top - TIP_BELOW_TOP]])
        pivot = np.concatenate([middle[:2] + direction[:2] * float(along.max()), [bottom]])
        axis = np.cross([0.0, 0.0, 1.0], direction)
        arc = []
        for step in range(TIP_STEPS + 1):
            turn = rotation_about(axis, TIP_ANGLE * step / TIP_STEPS)
            at = pivot + turn @ (contact - pivot) - turn @ direction * FINGER_HALF_THICKNESS
            arc.append(np.concatenate([at, orientation]))
        start = shifted(arc[0], -direction * TIP_START_GAP)
        planned = motion.mark()
        try:
            qpos = motion.current_qpos()
            motion.hold(qpos, 1.0, GRIPPER_STEPS)  # closed: the fingers push as one block
            qpos = motion.move(qpos, raised(start, APPROACH_HEIGHT), f"reach beside '{name}'", straight=False)
            qpos = motion.move(qpos, start, f"come down beside '{name}'")
            paths = motion.straight_chain(qpos, arc)
            if paths is None:
                raise OracleFailure(f"cannot push '{name}' over: no straight moves along the arc")
            for path in paths:
                qpos = motion.queue(qpos, path)
        except OracleFailure as error:
            motion.rewind(planned)
            failure = error
            continue
        try:  # the object is over: rising away is a courtesy, not a must
            qpos = motion.move(qpos, raised(arc[-1], APPROACH_HEIGHT), f"raise the hand from '{name}'")
        except OracleFailure:
            pass
        motion.hold(qpos, 0.0, GRIPPER_STEPS)
        return
    raise failure
