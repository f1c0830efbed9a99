"""The oracle: a privileged policy that solves tasks from the simulator's true state with a motion planner.

It reads the task's success condition and the true object poses, turns them into pick-and-place jobs (which
object, where to put it), plans each move with mplib (straight lines through inverse-kinematics waypoints a
centimetre apart, mplib's screw motion at the edge of the workspace, RRT-Connect when no straight line is free),
grasps top-down where the hand clears the neighbours (from a grid of ray casts), sets objects down on a free flat
spot of a bin's floor or a plate within reach (another grid of ray casts) and replays the plan as the same 8-D
DROID actions a learned policy sends: 7 absolute joint targets and the gripper (0 open, 1 closed) at the control
rate. It plans one job (one object) at a time from the state it finds; when a job is over it checks the task's
condition for that object, and a job that did not get there (the object slipped, tipped or was never held) is planned
again from the new state, up to JOB_RETRIES times. When it cannot go on it raises OracleFailure saying why.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
from gymnasium import spaces

from robolab_ms.catalog.procedural import quat_to_matrix
from robolab_ms.errors import RoboLabError
from robolab_ms.policies import Policy
from robolab_ms.policies.oracle_balance import balance_grasp, head_first_place
from robolab_ms.policies.oracle_carry import held_spread, high_carry
from robolab_ms.policies.oracle_centred import centred_grasp, off_part
from robolab_ms.policies.oracle_chord import chord_grasp
from robolab_ms.policies.oracle_clear import arm_hits_fixture, fixture_closeness, move_for_chain, reach_over_clear
from robolab_ms.policies.oracle_handle import handle_grasp
from robolab_ms.policies.oracle_lying import lying_container, stand_before_moving
from robolab_ms.policies.oracle_overhang import STEP_LIFT, STEP_SETTLE_STEPS, side_step, side_step_path
from robolab_ms.policies.oracle_pads import pads_snag
from robolab_ms.policies.oracle_release import backed_off, settle_pose, turned_place
from robolab_ms.policies.oracle_reorient import end_grasp, turned_rim_grasps
from robolab_ms.policies.oracle_sag import sagging_reach_height
from robolab_ms.policies.oracle_share import shared_spot
from robolab_ms.policies.oracle_side import side_hold_job
from robolab_ms.policies.oracle_tools import draw_nearer, far_tool, higher_hold, reachable_above
from robolab_ms.tasks.predicates import PREDICATES, per_object

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

APPROACH_HEIGHT = 0.10  # m above the grasp, and above the place point, where straight moves start and end
LIFT_HEIGHT = 0.15  # m an object is lifted before it travels
RELEASE_CLEARANCE = 0.03  # m between the held object's bottom and the place surface when the gripper opens
GRIPPER_STEPS = 8  # control steps to close or open the gripper (about half a second)
SETTLE_STEPS = 3  # control steps held at the end of every move, for the PD controller to catch up
BACK_OFF = 0.06  # m the hand backs away (and rises) after setting an object down upright
PART_RADIUS = 0.03  # m: the points around a grasped part that decide its closing direction and height
GRASP_DEPTH = 0.03  # m below an object's top where the TCP (the middle of the finger pads) closes ...
FINGERTIP_CLEARANCE = 0.004  # ... but the closed fingertips at least this high above its bottom (off the table)
# How far the pads' lower ends reach below the TCP once closed on a part this wide (m): the Robotiq 2F-85's pads
# swing down as they close (measured on the droid robot); a Panda's fingers reach less far, so this is on the safe side.
PAD_DROP_WIDTHS = (0.0, 0.024, 0.036, 0.047, 0.057, 0.067, 0.077, 0.086)
PAD_DROP = (0.020, 0.020, 0.019, 0.0173, 0.0153, 0.0127, 0.0096, 0.0061)
MAX_GRASP_WIDTH = 0.078  # m: the widest part the open fingers (8.6 cm apart) go round with some room
FIT_TURN_STEP = 3.0  # degrees between the closing directions tried where the narrowest spread does not fit
OPEN_FINGER_GAP = 0.086  # m between the open fingers' pads
SECTION_STEP = 0.005  # m between the heights at which a part's width is measured
SNUG_MARGIN = 0.012  # m: a part held this little narrower than the open fingers' gap is still touched by both pads ...
SLIDE_OFF = 0.012  # ... so after letting go the hand moves this far along the closing direction before it rises
GRASP_TURNS = (0, 15, -15, 30, -30, 45, -45, 60, -60, 75, -75, 90)  # degrees from the narrowest closing direction
MAX_SHIFT_SHARE = 0.3  # a grasp moves along a part by at most this share of its length
CLASH_COST = 0.1  # m of shift that a metre of neighbour in the hand's way is worth (the hand pushes it aside) ...
BODY_CLASH_TOLERANCE = 0.08  # ... as long as it rises at most this far into the space of the gripper's body
FINGER_CLASH_TOLERANCE = 0.03  # ... and at most this far into the space the open fingers sweep
FINGER_SNAG = 0.005  # m: a neighbour rising this far into the open fingers' space may be pinched with the object,
# so a grasp whose fingers clear every neighbour (and that fits between them) wins over the untouched one
LONG_MAX_TURN = 30  # degrees: a light long object is closed on at most this far turned from across it
WIDTH_COST = 2.0  # m of shift that a metre more between the closed fingers is worth (a narrow hold is firm) ...
FIRM_WIDTH = 0.05  # ... down to this width (narrower is no firmer: a thin handle or knob is no better a hold)
TURN_COST = 0.005  # m of shift that a turn by one step of GRASP_TURNS is worth when choosing between grasps
GRASP_SHIFTS = (0.0, 0.015, -0.015, 0.03, -0.03, 0.045, -0.045, 0.06, -0.06)  # m along the part from its middle
HEAVY_MASS = 0.8  # kg: an object this heavy is held near its centre of mass, like a long one
LONG_TOOL_MASS = 0.1  # kg: a long object this heavy (a hammer, a clamp, a ladle) is a tool: turned to fit its place
LONG_RATIO = 2.0  # a footprint this many times as long as wide is held near its centre of mass
FOOTPRINT_CELL = 0.006  # m between the vertical rays that map the top of an object with few surface points ...
FOOTPRINT_MAX_POINTS = 200  # ... as many as this at most (a primitive's corners, not a mesh)
MIN_SLAB_POINTS = 12  # the fewest object points between the fingers that tell the width they close on
FINGER_HALF_WIDTH = 0.015  # m: object points this near the fingers' plane are between them
# The hand coming straight down to a top-down grasp, as boxes in its own frame: half extent along the hand's x,
# half extent along the closing direction, and how far below the TCP the box reaches (negative: above it).
HAND_PARTS = ((0.014, 0.075, 0.008), (0.037, 0.042, -0.053), (0.06, 0.06, -0.155))
HAND_MARGIN = 0.004  # m kept between the hand and anything else on the way down
OBSTACLE_RADIUS = 0.2  # m around a grasp where the tops of other objects are looked at, on a grid ...
OBSTACLE_CELL = 0.008  # ... of this spacing
OBSTACLE_CEILING = 0.8  # m: rays looking for objects start this high
RAY_PASSES = 64  # links of the robot and the object itself a looking ray may pass ...
RAY_SKIP = 0.005  # ... stepping this far past a robot link it meets
IK_RETRIES = 200  # random starts for inverse kinematics when the planner's own 20 found no solution
WALL_GRASP_DEPTH = 0.02  # m below the rim where the TCP closes on the wall of a standing container too wide to hold
WALL_GRASP_TURNS = 24  # directions around a standing container tried for a wall grasp
WALL_MAX_THICKNESS = 0.03  # m: a rim thicker than this is no wall to pinch
COMFORTABLE_REACH = 0.55  # m from the robot's base where the arm grasps from above most easily
STANDING_TILT = 0.3  # rad: a container tilted less than this stands (its rim can be pinched from above)
HANDLE_REACH = 0.04  # m beyond a wall where a handle would meet the outer finger ...
HANDLE_HALF_WIDTH = 0.02  # ... within this far to either side of it ...
PAD_LENGTH = 0.03  # ... as far below the TCP as the pads reach
RIM_DEPTH = 0.02  # m the TCP reaches into a lying container's opening for a rim grasp ...
RIM_APPROACH = 0.06  # ... after moving in straight from this far outside it
PIVOT_STEPS = 6  # straight moves that tip a lying container up about its base
TRAVEL_RADIUS = 0.15  # m: objects this near (horizontally) a pose above a grasp or a place point ...
TRAVEL_CLEARANCE = 0.04  # ... are passed this high above, by the fingertips or the held object
FINGERTIP_BELOW_TCP = 0.01  # m the fingertips reach below the TCP
PASS_RADIUS = 0.08  # m (horizontally) from the hand's way to a grasp within which objects must be passed above ...
PASS_SAMPLES = 25  # ... checked at this many points along the way
PANDA_ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FLANGE_LINK = "panda_link8"
PLANNING_JOINT_SPEED = 1.2  # rad/s, well under the Panda's limits: smooth moves the PD controller can follow
PLANNING_JOINT_ACCELERATION = 1.5  # rad/s^2
JOINT_PATH_RESOLUTION = 0.05  # rad between the configurations checked for self-collision along a joint path
STRAIGHT_STEP = 0.01  # m between the waypoints of a straight move, each solved by inverse kinematics ...
STRAIGHT_TURN = 0.05  # ... or rad of turn between them
JOB_RETRIES = 2  # times a job whose object did not get where the condition wants it is planned again
JOB_SETTLE_STEPS = 10  # control steps held still before a job's object is checked a second time (it may still roll)
DENSE_EDGE = 0.01  # m: a retried grasp measures a mesh object's widths on its collision hulls' faces cut this fine
FAILED_GRASP_RADIUS = 0.025  # m: a grasp this near one whose job failed (same closing within 30 degrees) comes last
SLIP_DISTANCE = 0.05  # m the held object may move away from the hand (its grip settled) before it counts as slipped
MAX_JOINT_JUMP = 0.25  # rad a joint may change between two waypoints of a straight move (more: a flip, not a line)


class OracleFailure(RoboLabError):
    """The oracle cannot solve this episode; the message says why."""


@dataclass(frozen=True)
class Job:
    """Move one object: onto or into the object `onto`, onto the table with the middle of its footprint at `at`
    (x, y), up by `lift` metres, or stand it upright where it lies (`upright`). Onto an object: at a free flat
    spot of it (a bin's floor, a plate), or at its middle when `centred` (stacking)."""

    obj: str
    onto: str | None = None
    centred: bool = False
    at: tuple[float, float] | None = None
    lift: float = 0.0
    upright: bool = False


SIDE_OFFSET = 0.15  # m from a reference's centre to where an object is put beside it (left of, behind, ...)
DIRECTIONS = {"left_of": (0.0, 1.0), "right_of": (0.0, -1.0), "in_front_of": (-1.0, 0.0), "behind": (1.0, 0.0)}
TABLE_SAFE_X, TABLE_SAFE_Y = (0.30, 0.75), (-0.40, 0.40)  # where the oracle may put things down (robot frame, m)
SPOT_MARGIN = 0.03  # m of table kept clear around an object the oracle puts down
PLACE_CELL = 0.01  # m between the rays that map a container's floor or a plate when choosing where to set down
PLACE_FLATNESS = 0.02  # m a place spot may rise above the lowest point of the container or plate
OPEN_FINGER_REACH = 0.05  # m from the TCP to the outer face of an open finger, along the closing direction
PLACE_MARGIN = 0.015  # m kept between an object set down in a container or on a plate and what is already there
PLACE_TURNS = (0, 15, -15, 30, -30, 45, -45, 60, -60, 75, -75, 90)  # degrees the hand may turn to fit a place
PLACE_MIDDLE = 0.04  # m: a long object too big for a floor has at least this much around its middle over it
PLACE_REACH_TRIES = 12  # free spots tried for reach where the middle is out of reach ...
PLACE_REACH_MARGIN = 0.04  # ... and the one chosen this much nearer the robot than the farthest reached, if free


# The predicates jobs_for turns into jobs (of a task's first success condition).
SOLVABLE_PREDICATES = ("in_container", "enclosed", "on_top", "on_center", "placed_in_container_in_order",
                       "groups_in_containers", "stacked", "picked_up", *DIRECTIONS, "next_to", "upright", "outside_of",
                       "outside_of_and_on_surface")  # fmt: skip


def jobs_for(env: RoboLabEnv) -> list[Job]:
    """The pick-and-place jobs that satisfy the task's first success condition."""
    condition = env.task_spec.success[0]
    objects = list(condition.objects)
    if condition.logical == "any":
        objects = objects[:1]
    elif condition.logical == "choose":
        objects = objects[: condition.k]
    predicate, references, params = condition.predicate, condition.references, condition.params
    if predicate in ("in_container", "enclosed", "on_top", "on_center", "placed_in_container_in_order"):
        reference = next(iter(references.values()))
        if predicate in ("on_top", "on_center") and condition.logical == "all" and len(objects) > 2:
            objects = _largest_first(env, objects)  # all of many onto a plate: the last, largest one finds no room
        return [Job(name, onto=reference, upright=lying_container(env, name)) for name in objects]
    if predicate == "groups_in_containers":
        home = {name: container for container, members in params["groups"].items() for name in members}
        return [Job(name, onto=home[name]) for name in objects]
    if predicate == "stacked":
        order = objects[::-1] if params.get("order") == "top_to_bottom" else objects
        return [Job(upper, onto=lower, centred=True) for lower, upper in zip(order, order[1:])]
    if predicate == "picked_up":
        return [Job(name, lift=params.get("distance", 0.05) + 0.05) for name in objects[:1]]
    if predicate in DIRECTIONS or predicate == "next_to":
        reference = references["reference"]
        dx, dy = DIRECTIONS.get(predicate, (0.0, 1.0))
        centre = _centre(env, reference)
        return [Job(name, at=(centre[0] + dx * SIDE_OFFSET, centre[1] + dy * SIDE_OFFSET)) for name in objects[:1]]
    if predicate == "upright":
        tolerance = params.get("tolerance", 0.1)
        return [Job(name, upright=True) for name in objects if _tilt(env, name) > tolerance]
    if predicate in ("outside_of", "outside_of_and_on_surface"):
        env.eval_context.refresh()
        objects = _top_first(env, objects)  # a stack is taken apart from the top
        footprints: list[np.ndarray] = []
        for name in objects:  # an object taken off a shelf level goes down near where it is, not behind the shelf
            near = shelf_exit_spot(env, name) if not env.scene.gpu_sim_enabled and covered(env, name) else None
            if near is not None and not (
                TABLE_SAFE_X[0] <= near[0] <= TABLE_SAFE_X[1] and TABLE_SAFE_Y[0] <= near[1] <= TABLE_SAFE_Y[1]
            ):
                near = _centre(env, name)[:2]  # no room beside the shelf (a long object): near where it lies
            moved = objects[: len(footprints) + 1]  # those not yet moved still stand where they are
            footprints.append(free_spot(env, name, avoid=moved, taken=footprints, near=near))
        return [
            Job(name, at=tuple(float(v) for v in (box[:2] + box[2:]) / 2)) for name, box in zip(objects, footprints)
        ]
    raise OracleFailure(f"the oracle cannot yet solve '{predicate}' conditions (task {env.task_spec.name})")


def job_done(env: RoboLabEnv, job: Job) -> bool:
    """Whether the task's first success condition holds for the job's object now. True for conditions that
    hold only for all their objects together (a stack, an order of placing) and for objects they do not name."""
    condition = env.task_spec.success[0]
    if PREDICATES[condition.predicate].group or job.obj not in condition.objects:
        return True
    holds = per_object(env.eval_context, condition)
    return bool(holds[0, list(condition.objects).index(job.obj)])


def _largest_first(env: RoboLabEnv, objects: list[str]) -> list[str]:
    """`objects` by the area of their footprint (x, y box as they lie now), largest first; equal ones keep their
    order."""
    areas = {name: float(np.prod(np.ptp(_world_points(env, name)[:, :2], axis=0))) for name in objects}
    return sorted(objects, key=lambda name: -areas[name])


def _top_first(env: RoboLabEnv, objects: list[str]) -> list[str]:
    """`objects` in their order, except that one resting on another of them (its bottom within a centimetre of the
    other's top, their footprints overlapping) comes before it."""
    boxes = {name: (_world_points(env, name).min(axis=0), _world_points(env, name).max(axis=0)) for name in objects}

    def rests_on(upper: str, lower: str) -> bool:
        (low_u, high_u), (low_l, high_l) = boxes[upper], boxes[lower]
        overlap = bool(np.all(low_u[:2] < high_l[:2]) and np.all(low_l[:2] < high_u[:2]))
        return overlap and abs(low_u[2] - high_l[2]) < 0.01

    ordered = list(objects)
    for _ in range(len(ordered) ** 2):  # move an object before the first one it rests on, until none is after one
        moves = [
            (i, j) for i, upper in enumerate(ordered) for j, lower in enumerate(ordered[:i]) if rests_on(upper, lower)
        ]
        if not moves:
            break
        i, j = moves[0]
        ordered.insert(j, ordered.pop(i))
    return ordered


class OraclePolicy(Policy):
    """Solves tasks from privileged simulator state; the upper-bound row of a results table."""

    name = "oracle"
    needs_images = False
    privileged = True

    def __init__(self) -> None:
        self.env: RoboLabEnv | None = None
        self._planner = None
        self._planner_robot: str | None = None
        self.actions: deque[np.ndarray] = deque()

    def bind(self, env: Any) -> None:
        """Give the oracle the environment whose true state it reads (the unwrapped RoboLabEnv)."""
        self.env = env.unwrapped
        robot = self.env.robot_uids
        if self._planner_robot != robot:
            self._planner, self._planner_robot = _make_planner(self.env), robot
        flange = self.env.agent.robot.links_map[FLANGE_LINK].pose
        self._tcp_in_flange = (flange.inv() * self.env.tcp_pose()).sp  # fixed: the hand is rigid on the flange

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        if self.env is None:
            raise OracleFailure("the oracle reads the simulator: call bind(env) before reset()")
        _seed_inverse_kinematics(seed)
        self._sync_fixtures()
        self.jobs = deque(jobs_for(self.env))
        self.actions.clear()
        self.gripper = 0.0
        self._job: Job | None = None  # the job whose actions are being replayed
        self._job_settled = False  # whether the hand has held still once after it, before the second check
        self._retries: dict[str, int] = {}  # per object: jobs planned again
        self._grasps: dict[str, list[np.ndarray]] = {}  # per object: the top-down grasps its jobs were planned with
        self._closed_steps = 0  # actions replayed in a row with the gripper closed
        self._held_offset: float | None = None  # the held object's distance from the hand once the grip settled

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        while not self.actions:
            if self._job is not None and self._check_job():
                continue  # the hand holds still a moment before the job is checked again
            if not self.jobs:  # everything done: hold still with the gripper open
                return self._action(self._planner_qpos(), 0.0)
            job = self.jobs.popleft()
            self._job, self._job_settled = job, False  # _plan_job may hand the check to a job it queues
            try:
                self._plan_job(job)
            except OracleFailure:
                self._job = None
                self.actions.clear()  # a plan that failed half-way leaves nothing to replay
                if not self._retry(job, first=False):
                    raise
                continue
        action = self.actions.popleft()
        if self._job is not None and self._slipped(action):  # the rest of the job is moot: open, check, plan again
            self.actions.clear()
            self._hold(self._planner_qpos(), 0.0, GRIPPER_STEPS)
            action = self.actions.popleft()
        return action

    def _slipped(self, action: np.ndarray) -> bool:
        """Whether the object of the job being replayed has fallen away from the closed hand: once the grip has
        settled, its distance from the TCP grew by more than SLIP_DISTANCE."""
        if action[7] < 0.5:
            self._closed_steps, self._held_offset = 0, None
            return False
        self._closed_steps += 1
        if self._closed_steps < GRIPPER_STEPS + SETTLE_STEPS:
            return False
        offset = float(np.linalg.norm((self.env.objects[self._job.obj].pose.p[0] - self.env.tcp_pose().p[0]).cpu()))
        if self._held_offset is None:
            self._held_offset = offset
        return offset > self._held_offset + SLIP_DISTANCE

    def _check_job(self) -> bool:
        """After a job's actions: whether its object satisfies the task's condition; if not, hold still once
        (True: actions were queued) and then plan the job again. Group conditions (a stack, an order) hold only
        when every job is done, so their jobs are not checked."""
        job = self._job
        if job_done(self.env, job):
            self._job = None
            return False
        if not self._job_settled:
            self._job_settled = True
            self._hold(self._planner_qpos(), 0.0, JOB_SETTLE_STEPS)
            return True
        self._job = None
        self._retry(job, first=True)  # with another grasp: the one that failed comes last (grasp_pose's `failed`)
        return False

    def _retry(self, job: Job, first: bool) -> bool:
        """Queue `job` again, at the front of the jobs when `first` (planned next), else after the others, unless
        its object has used up its retries; whether it was queued."""
        used = self._retries.get(job.obj, 0)
        if used >= JOB_RETRIES:
            return False
        self._retries[job.obj] = used + 1
        if first:
            self.jobs.appendleft(job)
        else:
            self.jobs.append(job)
        return True

    # ------------------------------------------------------------------------------------------------ planning
    def _plan_job(self, job: Job) -> None:
        env = self.env
        if job.upright and job.onto is not None:  # a lying container stood up first where it can be, then moved
            if stand_before_moving(self, job):
                self._job = None  # only the stand-up is queued: the move queued after it is the job checked
                return
            job = self._job = Job(job.obj, onto=job.onto, centred=job.centred)
        if job.upright:
            self._plan_reorientation(job.obj)
            return
        if not env.scene.gpu_sim_enabled and covered(env, job.obj):  # on a shelf level under another
            self._plan_front_job(job)
            return
        if side_hold_job(self, job):  # a long tool in a bin, its handle out over the wall: held there from the side
            return
        failed = self._grasps.setdefault(job.obj, [])
        grasp = grasp_pose(env, job.obj, failed=failed)
        failed.append(grasp)  # a job that succeeds is not planned again, so only failed grasps are looked at
        held_offset = grasp[:2] - _centre(env, job.obj)[:2]  # from the middle of the footprint to the TCP
        held_bottom = grasp[2] - object_bottom(env, job.obj)  # TCP height above the object's bottom
        snug = _snug(env, job.obj, grasp)
        around = held_spread(env, job.obj, grasp)  # how far the held object reaches from the TCP
        if job.onto is not None or job.at is not None:  # planned before the grasp, which holds the object as it is
            spread = job.onto is not None and not job.centred  # onto a free spot of a bin's floor or a plate
            reachable = self._can_place_from_above_or_front(job.obj, grasp)
            spot = None
            if spread:  # a ladle bowl-first; else a free spot with the hand as grasped, else turned about the vertical
                spot = (
                    shared_spot(self, job, grasp, held_bottom, reachable)
                    or head_first_place(env, job.obj, job.onto, grasp, held_bottom, reachable)
                    or free_place(env, job.obj, job.onto, grasp, held_bottom, reachable)
                    or turned_place(env, job.obj, job.onto, grasp, held_bottom, reachable)
                )
            place, above_place = spot if spot is not None else place_pose(env, job, grasp, held_bottom, held_offset)
        qpos = self._planner_qpos()
        sideways = side_step_path(env, job.obj, grasp)  # (beside, over): in under an overhang, else None
        above_grasp = _above(env, grasp if sideways is None else sideways[0], APPROACH_HEIGHT, hanging=0.0)
        far = sideways is None and far_tool(env, job.obj, grasp)  # a heavy tool at the edge of the arm's reach
        if far:
            above_grasp = reachable_above(self, grasp, above_grasp)
        qpos = reach_over_clear(self, qpos, above_grasp, grasp if sideways is None else sideways[0], job.obj)
        if sideways is not None:
            qpos = self._move(qpos, sideways[0], f"descend beside '{job.obj}'")
            qpos = self._move(qpos, sideways[1], f"move in over '{job.obj}'")
            self._hold(qpos, 0.0, STEP_SETTLE_STEPS)  # the pads go down millimetres from the object's edges
        if snug and sideways is None:  # the open pads pass it with millimetres to spare: first settle just above it
            qpos = self._move(qpos, settle_pose(env, job.obj, grasp), f"settle over '{job.obj}'")
            self._hold(qpos, 0.0, STEP_SETTLE_STEPS)
        qpos = self._move(qpos, grasp, f"descend to '{job.obj}'")
        self._hold(qpos, 1.0, GRIPPER_STEPS)
        if far:  # drawn nearer the robot, just off the floor, where the arm can lift it
            qpos, grasp = draw_nearer(self, qpos, grasp, job.obj)
        if job.onto is None and job.at is None and sideways is None:
            self._move(qpos, _raised(grasp, job.lift), f"lift '{job.obj}'")
            return
        lifted = _above(env, grasp, LIFT_HEIGHT, hanging=held_bottom, held=job.obj)
        if sideways is not None:  # back out from under the overhang, then up
            qpos = self._move(qpos, _raised(sideways[1], STEP_LIFT), f"raise '{job.obj}' off the table")
            qpos = self._move(qpos, _raised(sideways[0], STEP_LIFT), f"move '{job.obj}' out from under the overhang")
            if job.onto is None and job.at is None:
                self._move(qpos, _raised(sideways[0], STEP_LIFT + job.lift), f"lift '{job.obj}'")
                return
            lifted = _above(env, _raised(sideways[0], STEP_LIFT), LIFT_HEIGHT, hanging=held_bottom, held=job.obj)
        carry = high_carry(env, job.obj, lifted, above_place, held_bottom, around, job.onto)
        qpos = self._move(qpos, lifted if carry is None else carry[0], f"lift '{job.obj}'")
        where = f"'{job.onto}'" if job.onto else f"the table at ({job.at[0]:.2f}, {job.at[1]:.2f})"
        try:
            if carry is not None:  # over something tall on the way, at one height, then down to the pose over the place
                qpos = self._move(qpos, carry[1], f"carry '{job.obj}' high over {where}")
            qpos = self._move(qpos, above_place, f"carry '{job.obj}' over {where}", straight=False)
        except OracleFailure:  # too high above a shelf: in from the front, if there is a way
            way = self._front_place_way(job.obj, grasp, place)
            if way is None:
                raise
            self._plan_front_place(qpos, job.obj, way, place, where)
            return
        qpos = self._move(qpos, place, f"lower '{job.obj}' onto {where}")
        self._hold(qpos, 0.0, GRIPPER_STEPS)
        if snug:
            qpos = self._slide_off(qpos, place, job.onto)
        self._move(qpos, above_place, f"retreat from {where}")

    def _front_place_way(self, name: str, grasp: np.ndarray, place: np.ndarray) -> np.ndarray | None:
        """Where the TCP, holding `name` as grasped at `grasp`, waits in front of a place on a shelf that it cannot
        be lowered to from high above: `place` raised by FRONT_PLACE_RISE and moved horizontally towards the robot
        until the hand and the object are clear of every fixture's footprint. None without fixtures, or where the
        hand would hit one on the way."""
        if not self._fixture_names:
            return None
        held = _world_points(self.env, name) - grasp[:3]
        toward = -place[:2] / np.linalg.norm(place[:2])
        return _outside(_raised(place, FRONT_PLACE_RISE), toward, _fixture_boxes(self.env), held)

    def _can_place_from_above_or_front(self, name: str, grasp: np.ndarray) -> Callable[[np.ndarray, np.ndarray], bool]:
        """A test for `free_place`: whether the arm holding `name` (grasped at `grasp`) reaches the pose over a
        place and lowers it straight from there, or else comes in horizontally from the front (`_front_place_way`)."""

        def reachable(over: np.ndarray, place: np.ndarray) -> bool:
            if self._can_lower(over, place):
                return True
            way = self._front_place_way(name, grasp, place)
            if way is None:
                return False
            status, postures = self._planner.IK(self._flange_target(way), self._planner_qpos())
            if status != "Success":
                return False
            start = self._planner_qpos()
            start[:7] = postures[0][:7]
            return self._straight_chain(start, [_raised(place, FRONT_PLACE_RISE), place]) is not None

        return reachable

    def _plan_front_place(self, qpos: np.ndarray, name: str, way: np.ndarray, place: np.ndarray, where: str) -> None:
        """Set the held object down on a high shelf from the front: carry it to `way` (see `_front_place_way`),
        slide it in horizontally over `place`, lower it, let go, and take the hand back up a little and out."""
        qpos = move_for_chain(
            self, qpos, way, [_raised(place, FRONT_PLACE_RISE), place], f"carry '{name}' in front of {where}"
        )
        qpos = self._move_straight(qpos, _raised(place, FRONT_PLACE_RISE), f"slide '{name}' in over {where}")
        qpos = self._move_straight(qpos, place, f"lower '{name}' onto {where}")
        self._hold(qpos, 0.0, GRIPPER_STEPS)
        try:  # the object is let go: taking the hand out is a courtesy, not a must
            qpos = self._move_straight(qpos, _raised(place, FRONT_PLACE_LEAVE), f"raise the hand off '{name}'")
            self._move_straight(qpos, _raised(way, FRONT_PLACE_LEAVE - FRONT_PLACE_RISE), f"retreat from {where}")
        except OracleFailure:
            pass

    def _slide_off(self, qpos: np.ndarray, place: np.ndarray, onto: str | None) -> np.ndarray:
        """After letting go of an object as wide as the open fingers (a tuna can), move the hand SLIDE_OFF along
        the closing direction, towards the middle of `onto`, so one pad pushes the object a little and the other
        comes off it (lifted straight away, both pads would carry it up); the posture is kept where that cannot be
        planned."""
        closing = quat_to_matrix(place[3:])[:, 1]
        towards = (_centre(self.env, onto)[:2] - place[:2]) if onto is not None else -place[:2]
        sign = 1.0 if float(closing[:2] @ towards) >= 0.0 else -1.0
        try:
            return self._move(
                qpos,
                _shifted(place, sign * SLIDE_OFF * closing * np.array([1.0, 1.0, 0.0])),
                "slide the fingers off the object",
            )
        except OracleFailure:
            return qpos

    def _reach_over(self, qpos: np.ndarray, above_grasp: np.ndarray, name: str) -> np.ndarray:
        """Queue the move from posture `qpos` to `above_grasp` (over object `name`); where something tall (a
        crate's wall) rises near the straight way there above it, the hand first goes over the grasp at a height
        that passes above everything on the way, then straight down. Returns the final joints."""
        what = f"reach above '{name}'"
        model, planner = self._planner.pinocchio_model, self._planner
        model.compute_forward_kinematics(qpos)
        flange = np.asarray(model.get_link_pose(planner.link_name_2_idx[FLANGE_LINK]))
        import sapien

        start = (sapien.Pose(p=flange[:3], q=flange[3:]) * self._tcp_in_flange).p
        height = _pass_height(self.env, np.asarray(start, dtype=np.float64), above_grasp[:3], name)
        if height is None:
            planned = len(self.actions)
            end = self._move(qpos, above_grasp, what, straight=False)
            height = sagging_reach_height(self, planned, name)  # the path itself dips onto a wall on the way
            if height is None:
                return end
            while len(self.actions) > planned:
                self.actions.pop()
            height = max(height, float(above_grasp[2]))
        transit = above_grasp.copy()
        transit[2] = height
        qpos = self._move(qpos, transit, what, straight=False)
        return self._move(qpos, above_grasp, f"come down over '{name}'")

    def _sync_fixtures(self) -> None:
        """Give the planner the episode's fixtures (shelves) as boxes, so that inverse kinematics and the planned
        moves keep the arm out of them (the other objects are left out: the hand reaches in among them)."""
        import mplib.pymp as mp

        fcl = mp.collision_detection.fcl
        for name in getattr(self, "_fixture_names", []):
            self._planner.remove_normal_object(name)
        self._fixture_names = []
        if self.env.scene.gpu_sim_enabled:
            return
        for index, (rotation, centre, half) in enumerate(_fixture_boxes(self.env)):
            name = f"fixture_{index}"
            box = fcl.CollisionObject(fcl.Box(2 * half), centre, _matrix_to_quaternion(rotation))
            self._planner.set_normal_object(name, box)
            self._fixture_names.append(name)

    def _collides(self, qpos: np.ndarray) -> bool:
        """Whether the arm at planning-model joints `qpos` collides with itself or a fixture."""
        planner = self._planner
        if planner.check_for_self_collision(qpos=qpos):
            return True
        return bool(self._fixture_names) and arm_hits_fixture(self, qpos)

    def _plan_front_job(self, job: Job) -> None:
        """Take an object off a shelf level under another one: the hand comes in leaning out of the shelf (see
        `front_grasps`), grasps, lifts the object off the level a little and pulls it straight out, then carries
        it on as `_plan_job` does. Grasps are tried in turn until one can be planned."""
        grasps = front_grasps(self.env, job.obj)
        if not grasps:
            raise OracleFailure(
                f"'{job.obj}' is under a shelf level and no hand leaning in from the open side clears the shelf"
            )
        planned, failure = len(self.actions), None
        for grasp in grasps:
            try:
                self._plan_front_attempt(job, grasp)
                return
            except OracleFailure as error:
                failure = error
                while len(self.actions) > planned:
                    self.actions.pop()
                self.gripper = 0.0
        raise failure

    def _plan_front_attempt(self, job: Job, grasp: FrontGrasp) -> None:
        """The moves of `_plan_front_job` with one front grasp."""
        env = self.env
        out = pulled_out(env, job.obj, grasp)
        if out is None:
            raise OracleFailure(f"cannot pull '{job.obj}' out of the shelf: the hand would hit it")
        held_offset = grasp.pose[:2] - _centre(env, job.obj)[:2]
        held_bottom = grasp.pose[2] - object_bottom(env, job.obj)
        if job.onto is not None or job.at is not None:
            spread = job.onto is not None and not job.centred
            spot = free_place(env, job.obj, job.onto, grasp.pose, held_bottom, self._can_lower) if spread else None
            place, above_place = (
                spot if spot is not None else place_pose(env, job, grasp.pose, held_bottom, held_offset)
            )
        qpos = self._planner_qpos()
        qpos = self._move(qpos, grasp.entry, f"reach in front of '{job.obj}'", straight=False)
        qpos = self._move(qpos, grasp.approach, f"reach in towards '{job.obj}'")
        qpos = self._move(qpos, grasp.pose, f"reach in to '{job.obj}'")
        self._hold(qpos, 1.0, GRIPPER_STEPS)
        qpos = self._move(qpos, _raised(grasp.pose, FRONT_LIFT), f"lift '{job.obj}' off its level")
        qpos = self._move(qpos, out, f"pull '{job.obj}' out of the shelf")
        if job.onto is None and job.at is None:
            self._move(qpos, _raised(out, job.lift), f"lift '{job.obj}'")
            return
        qpos = self._move(qpos, _raised(out, LIFT_HEIGHT), f"lift '{job.obj}'")
        where = f"'{job.onto}'" if job.onto else f"the table at ({job.at[0]:.2f}, {job.at[1]:.2f})"
        qpos = self._move(qpos, above_place, f"carry '{job.obj}' over {where}", straight=False)
        qpos = self._move(qpos, place, f"lower '{job.obj}' onto {where}")
        self._hold(qpos, 0.0, GRIPPER_STEPS)
        self._move(qpos, above_place, f"retreat from {where}")

    def _can_lower(self, over: np.ndarray, place: np.ndarray) -> bool:
        """Whether the arm reaches TCP pose `over` (by inverse kinematics) and from there moves straight to
        `place`."""
        status, postures = self._planner.IK(self._flange_target(over), self._planner_qpos())
        if status != "Success":
            return False
        start = self._planner_qpos()
        start[:7] = postures[0][:7]
        return self._plan_straight(self._flange_target(place), start)["status"] == "Success"

    def _plan_reorientation(self, name: str) -> None:
        """Stand a lying object up. A lying container is held by the top of its rim (one finger inside) and tipped
        up about the lowest point of its base, which stays on the table; anything else is grasped from above across
        its body, lifted, turned so its up axis points up, and set down where it lay."""
        env = self.env
        up = env.eval_context.up_axis(name)[0].cpu().numpy().astype(np.float64)
        flat = np.array([up[0], up[1], 0.0])
        if np.linalg.norm(flat) < 1e-3:
            raise OracleFailure(f"'{name}' is upside down: turning it over is not supported")
        flat /= np.linalg.norm(flat)
        planned = len(self.actions)
        if env.eval_context.entries[name].is_container:
            grasp = rim_grasp(env, name, up)
            # the hand may hold the rim either way up; near joint limits only one of them can be planned; turned
            # about the vertical where the hand would meet a neighbour on the line of the container's axis
            attempts = [
                lambda g=g: self._plan_pivot_upright(name, up, g)
                for turned in turned_rim_grasps(env, name, grasp)
                for g in (turned, _rolled(turned))
            ]
        else:
            closing = np.cross([0.0, 0.0, 1.0], flat)  # across the body, horizontal: the object turns about this axis
            attempts = [lambda c=c: self._plan_reorientation_holding(name, up, c) for c in (closing, -closing)]
            end = end_grasp(env, name, up)  # first: held by the narrow part at its top end and tipped up about its base
            if end is not None:
                attempts[:0] = [
                    lambda g=g: self._plan_pivot_upright(name, up, g, backing=np.array([0.0, 0.0, 1.0]))
                    for g in (end, _rolled(end))
                ]
        for attempt, plan in enumerate(attempts):
            try:
                plan()
                return
            except OracleFailure:
                while len(self.actions) > planned:
                    self.actions.pop()
                if attempt == len(attempts) - 1:
                    raise

    def _plan_pivot_upright(
        self, name: str, up: np.ndarray, grasp: np.ndarray, backing: np.ndarray | None = None
    ) -> None:
        """Hold a lying container by its rim (`grasp`, reached straight through its opening; or any grasp reached
        straight along `backing`, the direction the hand backs away from it) and tip it up about the lowest point
        of its base, which stays on the table, then let go and lift the hand. The arm posture at the grasp is
        chosen so that the whole tipping motion is one chain of straight moves."""
        env, planner = self.env, self._planner
        points = _world_points(env, name)
        base_end = points[points @ up < (points @ up).min() + 0.01]
        pivot = base_end[base_end[:, 2].argmin()]  # where the base touches the table: it stays there
        axis = np.cross(up, [0.0, 0.0, 1.0])
        angle = np.arccos(np.clip(up[2], -1.0, 1.0))
        hand = quat_to_matrix(grasp[3:])
        tipping = []
        for step in range(1, PIVOT_STEPS + 1):
            turn = _rotation_about(axis, angle * step / PIVOT_STEPS)
            tipping.append(np.concatenate([pivot + turn @ (grasp[:3] - pivot), _matrix_to_quaternion(turn @ hand)]))
        qpos = self._planner_qpos()
        status, postures = planner.IK(self._flange_target(grasp), qpos, n_init_qpos=IK_RETRIES)
        if status != "Success":
            raise OracleFailure(f"cannot reach the rim of '{name}': {status}")
        for posture in sorted(postures, key=lambda p: np.abs(p[:7] - qpos[:7]).sum()):
            at_grasp = qpos.copy()
            at_grasp[:7] = posture[:7]
            tip_paths = self._straight_chain(at_grasp, tipping)
            outside = _shifted(grasp, (up if backing is None else backing) * RIM_APPROACH)
            high = _raised(outside, APPROACH_HEIGHT) if backing is None else _above(env, outside, APPROACH_HEIGHT, 0.0)
            back_out = self._straight_chain(at_grasp, [outside, high])
            if tip_paths is not None and back_out is not None:
                break
        else:
            raise OracleFailure(f"cannot tip '{name}' up about its base: no arm posture allows the straight moves")
        # come in the way the hand would back out: down beside the opening, then straight in
        above_outside = at_grasp.copy()
        above_outside[:7] = back_out[-1][-1]
        result = self._plan_to_joints([above_outside], qpos)
        if result["status"] != "Success":
            raise OracleFailure(f"cannot reach the opening of '{name}': no motion plan ({result['status']})")
        self._queue(qpos, result["position"])
        way_in = np.concatenate([back_out[1][::-1], back_out[0][::-1][1:], [posture[:7]]])
        self._queue(above_outside, way_in)
        self._hold(at_grasp, 1.0, GRIPPER_STEPS)
        for path in tip_paths:
            self._queue(at_grasp, path)
        final = at_grasp.copy()
        final[:7] = tip_paths[-1][-1]
        self._hold(final, 0.0, GRIPPER_STEPS)
        try:  # the object stands and is let go: lifting the hand away is a courtesy, not a must
            self._move(final, _raised(tipping[-1], APPROACH_HEIGHT), f"lift the hand out of '{name}'")
        except OracleFailure:
            pass

    def _straight_chain(self, qpos: np.ndarray, poses: list[np.ndarray]) -> list[np.ndarray] | None:
        """Joint paths of consecutive straight moves through TCP `poses` from `qpos`, or None if one fails."""
        paths, current = [], qpos.copy()
        for pose in poses:
            result = self._plan_straight(self._flange_target(pose), current)
            if result["status"] != "Success":  # at the edge of the workspace: within a centimetre of the pose
                result = self._planner.plan_screw(self._flange_target(pose), current, time_step=self._time_step)
            if result["status"] != "Success":
                return None
            position = np.asarray(result["position"])
            if len(position) == 0:  # the screw motion found the hand already there: a path that stays put
                position = current[None, :7].copy()
            paths.append(position)
            current[:7] = paths[-1][-1]
        return paths

    def _queue(self, qpos: np.ndarray, path) -> np.ndarray:
        """Queue a joint path (rows of 7 arm joints) from posture `qpos`, then hold its end a moment; returns the
        final posture."""
        final = qpos.copy()
        for joints in path:
            final[:7] = joints
            self.actions.append(self._action(final, self.gripper))
        self._hold(final, self.gripper, SETTLE_STEPS)
        return final

    def _plan_reorientation_holding(self, name: str, up: np.ndarray, closing: np.ndarray) -> None:
        """Grasp `name` from above with the fingers closing along `closing`, lift it, tip its up axis to world z
        with the hand turned to point away from the robot, set it down where it lay and back off."""
        env = self.env
        grasp = grasp_pose(env, name, closing=closing, keep_sign=True)
        qpos = self._planner_qpos()
        qpos = self._move(qpos, _raised(grasp, APPROACH_HEIGHT), f"reach above '{name}'", straight=False)
        qpos = self._move(qpos, grasp, f"descend to '{name}'")
        self._hold(qpos, 1.0, GRIPPER_STEPS)
        qpos = self._move(qpos, _raised(grasp, LIFT_HEIGHT), f"lift '{name}'")
        tip = _rotation_between(up, np.array([0.0, 0.0, 1.0]))
        hand_axis = tip @ quat_to_matrix(grasp[3:])[:, 2]  # the fingers' direction after tipping
        outward = np.array([grasp[0], grasp[1], 0.0]) / np.linalg.norm(grasp[:2])
        turn = _rotation_between(np.array([hand_axis[0], hand_axis[1], 0.0]), outward)
        final_rotation = turn @ tip @ quat_to_matrix(grasp[3:])
        object_points = _world_points(env, name)
        lying_centre = (object_points.max(axis=0) + object_points.min(axis=0)) / 2
        object_in_hand = (object_points - grasp[:3]) @ (turn @ tip).T  # object points relative to the TCP, turned
        centre = (object_in_hand.max(axis=0) + object_in_hand.min(axis=0)) / 2
        target_xy = lying_centre[:2] - centre[:2]  # the object stands where it lay
        z = RELEASE_CLEARANCE - object_in_hand[:, 2].min()
        stand = np.concatenate([[target_xy[0], target_xy[1], z], _matrix_to_quaternion(final_rotation)])
        qpos = self._move(qpos, _raised(stand, APPROACH_HEIGHT), f"turn '{name}' upright", straight=False)
        qpos = self._move(qpos, stand, f"set '{name}' down upright")
        self._hold(qpos, 0.0, GRIPPER_STEPS)
        back = stand.copy()
        back[:3] += -final_rotation[:, 2] * BACK_OFF + np.array([0.0, 0.0, BACK_OFF])  # back along the fingers and up
        try:  # the object stands and is let go: moving the hand away is a courtesy, not a must
            qpos = self._move(qpos, back, f"back off from '{name}'")
            self._move(qpos, _raised(back, APPROACH_HEIGHT), f"raise the hand above '{name}'")
        except OracleFailure:
            pass

    def _move(self, qpos: np.ndarray, pose: np.ndarray, what: str, straight: bool = True) -> np.ndarray:
        """Queue the actions of one move to the TCP pose [x, y, z, qw, qx, qy, qz]; returns the final joints."""
        planner, step = self._planner, 1.0 / self.env.control_freq
        pose = self._flange_target(pose)
        result = self._plan_straight(pose, qpos) if straight else {"status": "not tried"}
        if straight and result["status"] != "Success":  # at the edge of the workspace: a straight line that may miss
            result = planner.plan_screw(pose, qpos, time_step=step)  # the pose by a centimetre, or none
        if result["status"] != "Success":
            status, goals = planner.IK(pose, qpos)
            if status != "Success":  # near the edge of the workspace: try harder
                status, goals = planner.IK(pose, qpos, n_init_qpos=IK_RETRIES)
            result = self._plan_to_joints(goals, qpos) if status == "Success" else {"status": status}
        if result["status"] != "Success":
            raise OracleFailure(f"cannot {what}: no motion plan ({result['status']}); the pose may be unreachable")
        return self._queue(qpos, result["position"])

    def _move_straight(self, qpos: np.ndarray, pose: np.ndarray, what: str) -> np.ndarray:
        """Queue a straight move of the TCP to `pose` (mplib's screw motion where the straight line fails), never
        a sampled path: for moves that must keep a held object on its line (out of a shelf); returns the final
        joints."""
        paths = self._straight_chain(qpos, [pose])
        if paths is None:
            raise OracleFailure(f"cannot {what}: no straight move")
        return self._queue(qpos, paths[0])

    @property
    def _time_step(self) -> float:
        return 1.0 / self.env.control_freq

    def _plan_straight(self, flange_pose: np.ndarray, qpos: np.ndarray) -> dict[str, Any]:
        """A timed joint path that moves the flange along a straight line (and the shortest turn) to `flange_pose`:
        inverse kinematics solved from the previous waypoint every STRAIGHT_STEP metres (or STRAIGHT_TURN radians),
        so the path ends on the pose to within a millimetre; fails on a joint limit, a jump or self-collision."""
        from scipy.spatial.transform import Rotation, Slerp

        planner = self._planner
        model, flange = planner.pinocchio_model, planner.link_name_2_idx[FLANGE_LINK]
        model.compute_forward_kinematics(qpos)
        start = np.asarray(model.get_link_pose(flange))
        turns = Rotation.from_quat([np.roll(start[3:], -1), np.roll(flange_pose[3:], -1)])  # (x, y, z, w) order
        angle = (turns[0].inv() * turns[1]).magnitude()
        distance = float(np.linalg.norm(flange_pose[:3] - start[:3]))
        count = max(1, int(np.ceil(max(distance / STRAIGHT_STEP, angle / STRAIGHT_TURN))))
        slerp = Slerp([0.0, 1.0], turns)
        lower, upper = np.asarray(planner.joint_limits)[:7].T
        current, path = qpos.copy(), [qpos[:7].copy()]
        for fraction in np.arange(1, count + 1) / count:
            waypoint = np.concatenate(
                [start[:3] + fraction * (flange_pose[:3] - start[:3]), np.roll(slerp(fraction).as_quat(), 1)]
            )
            solution, converged, _ = model.compute_IK_CLIK(flange, waypoint, current)
            solution = np.asarray(solution)
            if (
                not converged
                or np.any(solution[:7] < lower - 1e-3)
                or np.any(solution[:7] > upper + 1e-3)
                or np.abs(solution[:7] - current[:7]).max() > MAX_JOINT_JUMP
                or self._collides(solution)
            ):
                return {"status": "straight move failed"}
            current = solution
            path.append(current[:7].copy())
        _, position, *_ = planner.TOPP(np.asarray(path), 1.0 / self.env.control_freq)
        return {"status": "Success", "position": position}

    def _plan_to_joints(self, goals: list[np.ndarray], qpos: np.ndarray) -> dict[str, Any]:
        """A timed joint path to the first goal reachable by a straight line in joint space free of self-collision;
        a sampling planner (not reproducible) only when no straight line is free."""
        planner, step = self._planner, 1.0 / self.env.control_freq
        for goal in goals:
            count = int(np.ceil(np.max(np.abs(goal[:7] - qpos[:7])) / JOINT_PATH_RESOLUTION)) + 1
            path = np.linspace(qpos, goal, max(count, 2))
            if any(self._collides(point) for point in path):
                continue
            if count == 1:
                return {"status": "Success", "position": path[-1:, :7]}
            _, position, *_ = planner.TOPP(path[:, :7], step)
            return {"status": "Success", "position": position}
        return planner.plan_qpos_to_qpos(goals, qpos, time_step=step, planning_time=2.0)

    def _flange_target(self, tcp_pose: np.ndarray) -> np.ndarray:
        """The flange pose [x, y, z, qw, qx, qy, qz] that puts the TCP at `tcp_pose`."""
        import sapien

        flange = sapien.Pose(p=tcp_pose[:3], q=tcp_pose[3:]) * self._tcp_in_flange.inv()
        return np.concatenate([flange.p, flange.q])

    def _hold(self, qpos: np.ndarray, gripper: float, steps: int) -> None:
        self.gripper = gripper
        for _ in range(steps):
            self.actions.append(self._action(qpos, gripper))

    def _action(self, qpos: np.ndarray, gripper: float) -> np.ndarray:
        """The env's 8-D action from a planning-model joint vector: 7 arm joint targets, then the gripper."""
        return np.concatenate([qpos[:7], [gripper]]).astype(np.float32)

    def _planner_qpos(self) -> np.ndarray:
        """The planning model's joints (the Panda arm's 7, then its 2 fingers, kept open) from the robot's state."""
        arm = self.env.arm_qpos()[0].cpu().numpy().astype(np.float64)
        return np.concatenate([arm, [0.04, 0.04]])


def _seed_inverse_kinematics(seed: int) -> None:
    """Seed the C library's generator, from which the planner's inverse kinematics draws its random starts, so the
    oracle's plans depend on the episode seed only."""
    import ctypes

    ctypes.CDLL(None).srand(ctypes.c_uint(seed & 0xFFFFFFFF))


def _make_planner(env: RoboLabEnv):
    """An mplib planner for the robot's arm. Every supported robot has a Panda arm, so the planner uses ManiSkill's
    Panda model (with its collision pairs) and moves the flange, panda_link8; the hand on the flange differs per
    robot and is accounted for by the flange-to-TCP transform read from the robot (see OraclePolicy.bind)."""
    import mplib
    from mani_skill import PACKAGE_ASSET_DIR

    if tuple(env.robot.arm_joints) != PANDA_ARM_JOINTS:
        raise OracleFailure(f"the oracle plans for Panda arms (droid, panda); robot '{env.robot_uids}' has another arm")
    model = Path(PACKAGE_ASSET_DIR) / "robots" / "panda" / "panda_v2.urdf"
    return mplib.Planner(
        urdf=str(model),
        srdf=str(model.with_suffix(".srdf")),
        move_group=FLANGE_LINK,
        joint_vel_limits=np.full(7, PLANNING_JOINT_SPEED),
        joint_acc_limits=np.full(7, PLANNING_JOINT_ACCELERATION),
    )


# ------------------------------------------------------------------------------------------------ geometry
def _world_points(env: RoboLabEnv, name: str) -> np.ndarray:
    """The object's collision surface points in the world (N, 3)."""
    return _in_world(env, name, env.eval_context.entries[name].points)


def _in_world(env: RoboLabEnv, name: str, local: np.ndarray) -> np.ndarray:
    """Points (N, 3) given in object `name`'s frame, in the world."""
    ctx = env.eval_context
    rotation = ctx.rotation(name)[0].cpu().numpy()
    return local @ rotation.T + ctx.position(name)[0].cpu().numpy()


_DENSE_POINTS: dict[str, np.ndarray] = {}  # per catalog object: points on its collision hulls' faces, object frame


def _dense_world_points(env: RoboLabEnv, name: str) -> np.ndarray:
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
    return _in_world(env, name, _DENSE_POINTS[entry.name])


def object_bottom(env: RoboLabEnv, name: str) -> float:
    return float(_world_points(env, name)[:, 2].min())


def grasp_pose(
    env: RoboLabEnv,
    name: str,
    closing: np.ndarray | None = None,
    keep_sign: bool = False,
    failed: list[np.ndarray] = (),
) -> np.ndarray:
    """A top-down grasp [x, y, z, qw, qx, qy, qz] of the TCP. Of the candidate grasps (the fingers closing along
    `closing`, or along directions turned from the part's narrowest horizontal one; the hand centred on the
    object's footprint or moved along the part) the one whose hand clears the neighbours, then the one nearest the
    middle and least turned; candidates near a grasp in `failed` (earlier grasps of this object whose job did not
    succeed) only after all others. Where nothing of the object is at the middle of its footprint (a ring, a pair of
    glasses) its part nearest the middle is grasped. The height: a little below the part's top, lower on a part
    that is widest further down (a ball: its widest section that fits between the open fingers), and the closed
    fingertips clear of the table."""
    env.eval_context.refresh()
    points = _world_points(env, name)
    if len(failed):  # a grasp failed: measure on the faces too (between a mesh's hull corners a slab can look thin)
        points = np.concatenate([points, _dense_world_points(env, name)])
    bottom = points[:, 2].min()  # of the whole object: what the fingertips must stay clear of is below it
    centre = (points.max(axis=0) + points.min(axis=0)) / 2
    part_only = not _hits(env, name, centre[:2], points[:, 2].max())
    tool = _tool(env, name, points) or _heavy(env, name)
    if tool and closing is None:  # a heavy wide end (a ladle's bowl): by the handle beside it (oracle_balance)
        balanced = balance_grasp(env, name, failed)
        if balanced is not None:
            return balanced
    if tool:  # held far from its mass centre it twists out of the pads
        mass_centre = _mass_centre(env, name)
        seen = _footprint_points(env, name, points)
        if _hits(env, name, mass_centre[:2], points[:, 2].max()) or _spans(
            points if seen is None else seen, mass_centre
        ):
            centre, part_only = np.array([mass_centre[0], mass_centre[1], centre[2]]), False
    if part_only:  # the middle is empty: grasp the part of the object nearest to it
        mapped = _footprint_points(env, name, points)  # a primitive's corners may all lie far from that part
        if mapped is not None and len(mapped) >= MIN_SLAB_POINTS:
            nearest = mapped[np.linalg.norm(mapped[:, :2] - centre[:2], axis=1).argmin()]
            points = np.concatenate([points, mapped])
        else:
            nearest = points[np.linalg.norm(points[:, :2] - centre[:2], axis=1).argmin()]
        points = points[np.linalg.norm(points[:, :2] - nearest[:2], axis=1) < PART_RADIUS]
        centre = np.array([nearest[0], nearest[1], (points[:, 2].max() + points[:, 2].min()) / 2])
    footprint = _footprint_points(env, name, points) if tool and not part_only else None  # a tool's top, mapped
    if closing is None:
        spread = points if footprint is None or len(footprint) < MIN_SLAB_POINTS else footprint
        xy = spread[:, :2] - spread[:, :2].mean(axis=0)
        _, vectors = np.linalg.eigh(xy.T @ xy)
        narrowest = vectors[:, 0]  # the direction of least spread: the fingers close along it by preference
        narrowest = _fitting_direction(spread, narrowest)  # a square box: across its faces, not its diagonal
        directions = [_turned(narrowest, angle) for angle in GRASP_TURNS]
    else:
        directions = [np.asarray(closing[:2], dtype=np.float64)]
    heights = _obstacle_heights(env, name, centre[:2])
    long = _long_object(points)
    best, best_key = None, None
    for turn_rank, direction in enumerate(directions):
        direction = direction / np.linalg.norm(direction)
        along = np.array([-direction[1], direction[0]])  # the hand's x axis: the fingers' width runs along it
        reach = points[:, :2] @ along - centre[:2] @ along
        limit = MAX_SHIFT_SHARE * float(np.ptp(reach))
        shifts = [0.0] if part_only else [v for v in GRASP_SHIFTS if abs(v) <= limit]
        for shift in shifts or [0.0]:
            xy = centre[:2] + along * shift
            slab = points[np.abs(points[:, :2] @ along - xy @ along) < FINGER_HALF_WIDTH]
            if len(slab) < MIN_SLAB_POINTS and footprint is not None:  # a box has only its corners: the top seen
                slab = footprint[np.abs(footprint[:, :2] @ along - xy @ along) < FINGER_HALF_WIDTH]  # from above
            if len(slab) < MIN_SLAB_POINTS:  # too few surface points there to measure
                slab = points
            z, width = _grasp_height(slab, direction, bottom)
            fingers, body = _hand_clash(heights, xy, direction, z)
            if fingers > FINGER_CLASH_TOLERANCE and side_step(env, name, xy, direction, z, heights) is not None:
                fingers = 0.0  # an overhang the hand comes in under from the side (oracle_overhang)
            if tool and fingers > FINGER_CLASH_TOLERANCE:  # its widest part walled in (a drill's battery in a bin)
                z, width, fingers, body = higher_hold(slab, direction, heights, xy, (z, width, fingers, body))
            cost = (
                abs(shift) + TURN_COST * turn_rank + CLASH_COST * (fingers + body) + WIDTH_COST * max(width, FIRM_WIDTH)
            )
            # a little is pushed aside; more: the hand lands on it, or a finger catches on it (the pads grip)
            blocked = max(body - BODY_CLASH_TOLERANCE, 0.0) + max(fingers - FINGER_CLASH_TOLERANCE, 0.0)
            snag = not long and (fingers > FINGER_SNAG or width > MAX_GRASP_WIDTH)  # a utensil: across it, as before
            if long and not tool:  # ... but moved or turned where that keeps the closing pads off a neighbour (a plate)
                snag = (
                    width > MAX_GRASP_WIDTH
                    or pads_snag(heights, xy, direction, z, width)
                    or (closing is None and abs(GRASP_TURNS[turn_rank]) > LONG_MAX_TURN)
                )  # not closing along it
            key = (blocked > 0.0, round(blocked, 3), snag, shift != 0.0 or turn_rank > 0, cost)  # others if blocked
            if failed:
                key = (_near_failed(xy, direction, failed), *key)
            if best_key is None or key < best_key:
                best, best_key = (xy, z, direction), key
    xy, z, direction = best
    if long and not tool and closing is None and heights is not None and not part_only:  # a handle off the pads'
        seen = _footprint_points(env, name, points)  # middle (oracle_centred)
        if off_part(seen, xy, direction):
            xy, z, direction = centred_grasp(seen, directions, bottom, heights) or (xy, z, direction)
    # a wall grasp needs ray casts, which the oracle does only on the CPU simulator (where `heights` exist)
    wide = closing is None and heights is not None and _too_wide(points, direction, z)
    standing = closing is None and heights is not None and not tool and _standing_container(env, name)
    handle = handle_grasp(env, name, heights) if standing else None  # a light cup by its long handle
    if handle is not None:
        return handle
    if wide and _standing_container(env, name):
        wall = wall_grasp(env, name, heights)
        if wall is not None:
            return wall
    if closing is None and heights is not None and not tool and not part_only and not long:  # a can too wide
        chord = chord_grasp(env, name, points, centre, directions, bottom, heights, list(failed))  # for the middle
        if chord is not None:
            xy, z, direction = chord
    return np.concatenate([[xy[0], xy[1], z], _down_quaternion(direction, keep_sign)])


def _near_failed(xy: np.ndarray, closing: np.ndarray, failed: list[np.ndarray]) -> bool:
    """Whether a grasp at `xy` closing along `closing` is within FAILED_GRASP_RADIUS of one in `failed`, closing
    along nearly the same line."""
    for pose in failed:
        other = quat_to_matrix(pose[3:])[:2, 1]  # the hand's y axis: its closing direction
        if np.linalg.norm(pose[:2] - xy) < FAILED_GRASP_RADIUS and abs(float(closing @ other)) > np.cos(np.radians(30)):
            return True
    return False


def _snug(env: RoboLabEnv, name: str, grasp: np.ndarray) -> bool:
    """Whether the object, at the height of top-down `grasp`, is within SNUG_MARGIN as wide along the closing
    direction as the open fingers' gap (the opened pads still touch it)."""
    points = _world_points(env, name)
    closing = quat_to_matrix(grasp[3:])[:, 1]
    slab = points[np.abs(points[:, 2] - grasp[2]) < 2 * SECTION_STEP]
    return len(slab) >= 2 and float(np.ptp(slab @ closing)) > OPEN_FINGER_GAP - SNUG_MARGIN


def _fitting_direction(points: np.ndarray, narrowest: np.ndarray) -> np.ndarray:
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


def _mass_centre(env: RoboLabEnv, name: str) -> np.ndarray:
    """The object's centre of mass in the world (x, y, z), from the simulator's body."""
    actor = env.objects[name]
    body = actor._bodies[0]
    return np.asarray((actor.pose.sp * body.cmass_local_pose).p, dtype=np.float64)


def _mass(env: RoboLabEnv, name: str) -> float:
    """The object's mass in kg, from the simulator's body."""
    return float(env.objects[name]._bodies[0].mass)


def _heavy(env: RoboLabEnv, name: str) -> bool:
    """Whether the object weighs HEAVY_MASS or more (a drill): held off its mass centre, it turns in the pads."""
    return _mass(env, name) >= HEAVY_MASS


def _tool(env: RoboLabEnv, name: str, points: np.ndarray) -> bool:
    """Whether the object is a long tool (a hammer, a clamp, a ladle): long and LONG_TOOL_MASS or heavier."""
    return _long_object(points) and _mass(env, name) >= LONG_TOOL_MASS


def _long_object(points: np.ndarray) -> bool:
    """Whether the object's footprint is long (a tool, a utensil): at least LONG_RATIO times as long as wide, and
    longer than the open fingers' gap."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    extents = np.ptp(xy @ vectors, axis=0)  # narrowest, then widest
    return bool(extents[1] > OPEN_FINGER_GAP and extents[1] > LONG_RATIO * extents[0])


def _spans(points: np.ndarray, at: np.ndarray) -> bool:
    """Whether the open fingers, closing across the object's narrowest horizontal direction at `at`, go round
    all of it there (a spring clamp's two handles)."""
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, vectors = np.linalg.eigh(xy.T @ xy)
    narrowest, along = vectors[:, 0], vectors[:, 1]
    slab = points[np.abs((points[:, :2] - at[:2]) @ along) < 2 * FINGER_HALF_WIDTH]
    return len(slab) >= 2 and float(np.ptp(slab[:, :2] @ narrowest)) < MAX_GRASP_WIDTH


def _footprint_points(env: RoboLabEnv, name: str, points: np.ndarray) -> np.ndarray | None:
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
            z = _ray_hit(env, name, np.array([x, y, top + 0.01]), -1.0)
            if z is not None:
                found.append((x, y, z))
                found.append((x, y, bottom))
    return np.array(found) if found else None


def _too_wide(points: np.ndarray, closing: np.ndarray, z: float) -> bool:
    """Whether the object, from height `z` up (where the open fingers come down round it), is wider along
    `closing` than the gap between them."""
    near = points[points[:, 2] >= z - 2 * SECTION_STEP]
    if len(near) < 2:  # the grasp is above the object (a thin part lying flat): nothing for the fingers to go round
        return False
    return float(np.ptp(near[:, :2] @ (closing / np.linalg.norm(closing)))) > OPEN_FINGER_GAP


def _standing_container(env: RoboLabEnv, name: str) -> bool:
    return env.eval_context.entries[name].is_container and _tilt(env, name) < STANDING_TILT


def wall_grasp(env: RoboLabEnv, name: str, heights: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray | None:
    """A top-down grasp [x, y, z, qw, qx, qy, qz] of a standing container too wide for the open fingers (a mug, a
    bowl): the fingers straddle its wall at the rim, one inside and one outside, closing across the wall. Of the
    directions around it, the one whose hand clears the neighbours and the container's own handle, at the distance
    from the robot's base that the arm reaches most easily; None where no wall is found."""
    points = _world_points(env, name)
    top = float(points[:, 2].max())
    rim = points[points[:, 2] > top - 0.01]
    centre = (rim[:, :2].max(axis=0) + rim[:, :2].min(axis=0)) / 2
    radius = float(np.linalg.norm(rim[:, :2] - centre, axis=1).max())
    best, best_key = None, None
    fixtures = [] if env.scene.gpu_sim_enabled else _fixture_boxes(env)
    for index in range(WALL_GRASP_TURNS):
        angle = 2 * np.pi * index / WALL_GRASP_TURNS
        outward = np.array([np.cos(angle), np.sin(angle)])
        wall = _wall_along(env, name, centre, outward, radius, top)
        if wall is None:
            continue
        inner, outer = wall
        xy = centre + outward * (inner + outer) / 2
        z = top - WALL_GRASP_DEPTH
        beyond = points[:, :2] - centre
        radial, tangential = beyond @ outward, np.abs(beyond @ np.array([-outward[1], outward[0]]))
        handle = bool(
            np.any(
                (radial > outer + HAND_MARGIN)
                & (radial < outer + HANDLE_REACH)
                & (tangential < HANDLE_HALF_WIDTH)
                & (points[:, 2] > z - PAD_LENGTH)
            )
        )
        fingers, body = _hand_clash(heights, xy, outward, z)
        comfort = abs(float(np.linalg.norm(xy)) - COMFORTABLE_REACH)  # then the side the arm reaches most easily
        near = round(fixture_closeness(fixtures, xy, z), 2)  # away from a shelf beside it, where the arm passes it
        key = (handle, fingers + body > 0.01, near, round(fingers + body, 3), comfort)
        if best_key is None or key < best_key:
            best, best_key = (xy, z, outward), key
    if best is None:
        return None
    xy, z, outward = best
    return np.concatenate([[xy[0], xy[1], z], _down_quaternion(outward)])


def _wall_along(
    env: RoboLabEnv, name: str, centre: np.ndarray, outward: np.ndarray, radius: float, top: float
) -> tuple[float, float] | None:
    """Inner and outer distance (m) from `centre` of the container's wall at its rim along `outward`, from vertical
    ray casts 2 mm apart; None where the rim there is not a thin wall."""
    at_rim = []
    for distance in np.arange(0.0, radius + 0.01, 0.002):
        start = np.array([*(centre + outward * distance), top + 0.02])
        hit = _ray_hit(env, name, start, -1.0)
        if hit is not None and hit > top - 0.01:
            at_rim.append(distance)
    if not at_rim:
        return None
    inner, outer = min(at_rim), max(at_rim)
    if outer - inner > WALL_MAX_THICKNESS or inner < 0.01:
        return None
    return inner, outer


def _turned(direction: np.ndarray, degrees: float) -> np.ndarray:
    angle = np.radians(degrees)
    cos, sin = np.cos(angle), np.sin(angle)
    return np.array([cos * direction[0] - sin * direction[1], sin * direction[0] + cos * direction[1]])


def _grasp_height(slab: np.ndarray, closing: np.ndarray, bottom: float) -> tuple[float, float]:
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
    drop = float(np.interp(width, PAD_DROP_WIDTHS, PAD_DROP))
    return max(z, bottom + drop + FINGERTIP_CLEARANCE), width


def _obstacle_heights(env: RoboLabEnv, name: str, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The top heights of everything but object `name`, the robot and the table, on a grid of vertical rays around
    `centre` (cell centres (K, 2), heights (K,), -inf where nothing is); None off the CPU simulator."""
    if env.scene.gpu_sim_enabled:
        return None
    cells, heights, names = _surface_grid(env, name, centre, OBSTACLE_RADIUS, OBSTACLE_CELL)
    return cells, np.where([other is None for other in names], -np.inf, heights)


def _hand_clash(
    heights: tuple[np.ndarray, np.ndarray] | None, xy: np.ndarray, closing: np.ndarray, z: float
) -> tuple[float, float]:
    """How far (m) anything else rises into the space that the open fingers, and the rest of the hand, sweep coming
    straight down to a grasp at (xy, z) with the fingers closing along `closing`; (0, 0) when the way is clear."""
    if heights is None:
        return 0.0, 0.0
    cells, tops = heights
    along = np.array([-closing[1], closing[0]])
    local = cells - xy
    u, v = np.abs(local @ along), np.abs(local @ closing)
    clashes = []
    for half_u, half_v, reach in HAND_PARTS:
        inside = (u <= half_u + HAND_MARGIN) & (v <= half_v + HAND_MARGIN)
        clashes.append(max(float(tops[inside].max(initial=-np.inf)) - (z - reach), 0.0))
    return clashes[0], max(clashes[1:])


def _hits(env: RoboLabEnv, name: str, xy: np.ndarray, top: float) -> bool:
    """Whether a ray cast straight down at `xy`, from just above the object's `top`, meets the object first (on the
    CPU simulator; elsewhere assumed)."""
    if env.scene.gpu_sim_enabled:
        return True
    return _ray_hit(env, name, np.array([xy[0], xy[1], top + 0.01]), -1.0) is not None


def place_pose(
    env: RoboLabEnv, job: Job, grasp: np.ndarray, held_bottom: float, held_offset: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where the TCP goes to release the held object, and where above it the object is carried first (see
    `_over_place`): centred over `job.onto` with the object's bottom just above its top (a container's rim must be
    cleared on the way down; `free_place` finds a better spot where it can), or just above the table with the
    middle of the object's footprint (`held_offset` from the TCP) at `job.at`."""
    if job.onto is not None:
        points = _world_points(env, job.onto)
        x, y = (points[:, :2].max(axis=0) + points[:, :2].min(axis=0)) / 2
        top = points[:, 2].max()
        if env.eval_context.entries[job.onto].is_container:  # over what already fills it (a keyboard over the rim)
            top = max(top, _contents_top(env, job.onto, points, job.obj))
    else:
        (x, y), top = np.asarray(job.at) + held_offset, 0.0
    place = np.concatenate([[x, y, top + RELEASE_CLEARANCE + held_bottom], grasp[3:]])
    return place, _over_place(env, place, held_bottom, job.obj, job.onto)[0]


def _contents_top(env: RoboLabEnv, container: str, points: np.ndarray, held: str) -> float:
    """The highest point of the objects (other than `held`) whose middle lies within the container's outline
    (`points`, its world points), or 0 where there are none."""
    low, high = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
    top = 0.0
    for other in env.objects:
        if other in (container, held):
            continue
        other_points = _world_points(env, other)
        middle = (other_points[:, :2].min(axis=0) + other_points[:, :2].max(axis=0)) / 2
        if np.all(middle >= low) and np.all(middle <= high):
            top = max(top, float(other_points[:, 2].max()))
    return top


def _surface_grid(
    env: RoboLabEnv, name: str, centre: np.ndarray, radius: float, cell: float
) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
    """The first thing that vertical rays meet, passing through the robot and object `name`, on a grid of `cell`
    spacing around `centre`: cell centres (K, 2), heights (K,; the table's, or 0, where no object is) and the
    names of the objects hit (None: the table or nothing)."""
    owner = {entity: other for other, actor in env.objects.items() for entity in actor._objs}
    robot = {link.entity for link in env.agent.robot._objs[0].links}
    steps = np.arange(-radius, radius + 1e-9, cell)
    cells = np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2) + centre
    heights, names = np.zeros(len(cells)), [None] * len(cells)
    down = np.array([0.0, 0.0, -1.0], dtype=np.float32)
    for index, (x, y) in enumerate(cells):
        z = OBSTACLE_CEILING
        for _ in range(RAY_PASSES):  # through the robot and the object itself, down to the first other object
            hit = env.scene.px.raycast(np.array([x, y, z], dtype=np.float32), down, z + 0.05)
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


def free_place(
    env: RoboLabEnv,
    name: str,
    onto: str,
    grasp: np.ndarray,
    held_bottom: float,
    reachable: Callable[[np.ndarray, np.ndarray], bool],
    first_pass: int = 0,
    turns: tuple[float, ...] = (),
) -> tuple[np.ndarray, np.ndarray] | None:
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
    target = _world_points(env, onto)
    low, high = target[:, :2].min(axis=0), target[:, :2].max(axis=0)
    middle = (low + high) / 2
    held_points = _world_points(env, name)[:, :2] - grasp[:2]  # the held object relative to the TCP
    radius = float(np.max(high - middle)) + PLACE_CELL
    cells, heights, names = _surface_grid(env, name, middle, radius, PLACE_CELL)
    on_target = np.array([other == onto for other in names])
    if not on_target.any():
        return None
    level = heights[on_target].min()
    flat = on_target & (heights <= level + PLACE_FLATNESS)
    others = np.array([other is not None and other != onto for other in names])
    is_container = env.eval_context.entries[onto].is_container
    free = []  # release poses, middlemost first
    # the object and the open fingers with room around; where nothing has that room, the object alone; the hand
    # turned about the vertical as little as needed (a long tool fits a bin only along it)
    # last, for a long object that fits no floor (its middle is what counts as in): its middle over the floor and the
    # rest over whatever is there (a rim), released above all of it
    tool = _tool(env, name, held_points)
    passes = ((True, True), (False, True), (False, False)) if tool else ((True, True), (None, True), (False, True))
    for pass_index, (with_fingers, whole) in enumerate(passes[first_pass:], start=first_pass):  # noqa: B007 (read after the loop)
        for turn in turns or (PLACE_TURNS if tool else PLACE_TURNS[:1]):  # only a long tool turns (a spoon fits
            # as held), unless `turns` are given (the hand turned by these degrees about the vertical)
            spin = _rotation_about(np.array([0.0, 0.0, 1.0]), np.radians(turn))
            held = held_points @ spin[:2, :2].T
            quaternion = _matrix_to_quaternion(spin @ quat_to_matrix(grasp[3:]))
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
            for tcp in candidates[order]:
                local = cells - tcp
                under = np.all((local >= foot_low) & (local <= foot_high), axis=1)
                middle_part = under if whole else np.all(np.abs(local - centre_offset) <= PLACE_MIDDLE, axis=1)
                if not flat[middle_part].all() and (is_container or on_target[middle_part & ~flat].any()):
                    continue  # on a wall, a rim or the edge (a plate may have the table under the fingers)
                near = np.all((local >= body_low - margin) & (local <= body_high + margin), axis=1)
                if others[near].any():
                    continue
                z = heights[under].max() + RELEASE_CLEARANCE + held_bottom
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

    def reached(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        overs = _over_place(env, pose, held_bottom, name, onto)
        for over in overs[:-1] if clearing[0] and len(overs) > 1 else overs:
            if reachable(over, pose):
                return pose, over
        return None

    found = reached(free[0])
    if found is not None:
        return found
    found = _reached_over_rim(free, reached)  # a spot nearer the robot that the held object reaches over the rim
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


def _reached_over_rim(
    free: list[np.ndarray],
    reached: Callable[[np.ndarray], tuple | None],
) -> tuple[np.ndarray, np.ndarray] | None:
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


def _centre(env: RoboLabEnv, name: str) -> np.ndarray:
    env.eval_context.refresh()
    points = _world_points(env, name)
    return (points.max(axis=0) + points.min(axis=0)) / 2


def free_spot(
    env: RoboLabEnv, name: str, avoid: list[str], taken: list[np.ndarray], near: np.ndarray | None = None
) -> np.ndarray:
    """A footprint [x_min, y_min, x_max, y_max] on the table where `name`, moved without turning, can be put down:
    SPOT_MARGIN clear of every other object's footprint (except those in `avoid`, which are on the move) and of the
    footprints in `taken`; of those, the one nearest the point `near` (x, y), else the middle of the safe area."""
    own = _world_points(env, name)[:, :2]
    half = (own.max(axis=0) - own.min(axis=0)) / 2
    xs, ys = np.meshgrid(np.linspace(*TABLE_SAFE_X, 19), np.linspace(*TABLE_SAFE_Y, 33))
    spots = np.stack([xs.ravel(), ys.ravel()], axis=1)
    boxes = list(taken)
    for other in env.objects:
        if other not in avoid and other != name:
            points = _world_points(env, other)[:, :2]
            boxes.append(np.concatenate([points.min(axis=0), points.max(axis=0)]))
    ok = np.ones(len(spots), dtype=bool)
    for box in boxes:
        centre, other_half = (box[:2] + box[2:]) / 2, (box[2:] - box[:2]) / 2
        gaps = np.abs(spots - centre) - half - other_half  # per axis; apart when either gap is wide enough
        ok &= gaps.max(axis=1) >= SPOT_MARGIN
    if not ok.any():
        raise OracleFailure(f"no free spot on the table for '{name}' {SPOT_MARGIN:.2f} m clear of everything else")
    middle = np.array([np.mean(TABLE_SAFE_X), np.mean(TABLE_SAFE_Y)]) if near is None else np.asarray(near)
    spot = spots[ok][np.linalg.norm(spots[ok] - middle, axis=1).argmin()]
    return np.concatenate([spot - half, spot + half])


def rim_grasp(env: RoboLabEnv, name: str, up: np.ndarray) -> np.ndarray:
    """A grasp [x, y, z, qw, qx, qy, qz] of a container lying on its side (its opening facing `up`, roughly
    horizontal): the hand points into the opening and the fingers close vertically on the top of the rim's wall,
    one finger inside the container and one above it."""
    env.eval_context.refresh()
    points = _world_points(env, name)
    reach = points @ up
    mouth = reach.max()
    near_mouth = points[reach > mouth - RIM_DEPTH - 0.01]
    top = near_mouth[near_mouth[:, 2].argmax()]  # the top of the wall beside the opening
    at = top + up * (mouth - RIM_DEPTH - top @ up)  # RIM_DEPTH inside the opening
    outer = _ray_hit(env, name, np.array([at[0], at[1], top[2] + 0.02]), -1.0)
    middle = (points[:, 2].max() + points[:, 2].min()) / 2
    inner = _ray_hit(env, name, np.array([at[0], at[1], middle]), 1.0)
    if outer is None or inner is None or not inner < outer:
        raise OracleFailure(f"no rim grasp on '{name}': cannot find the wall at the top of its opening")
    approach = -up / np.linalg.norm(up)
    closing = np.array([0.0, 0.0, 1.0])
    rotation = np.stack([np.cross(closing, approach), closing, approach], axis=1)
    return np.concatenate([[at[0], at[1], (inner + outer) / 2], _matrix_to_quaternion(rotation)])


def _ray_hit(env: RoboLabEnv, name: str, start: np.ndarray, direction_z: float) -> float | None:
    """Height where a vertical ray from `start` (up for +1, down for -1) first meets object `name`, if it does (on
    the CPU simulator only)."""
    if env.scene.gpu_sim_enabled:
        raise OracleFailure("rim grasps need ray casts, which the oracle does only on the CPU simulator")
    direction = np.array([0.0, 0.0, direction_z], dtype=np.float32)
    hit = env.scene.px.raycast(start.astype(np.float32), direction, 1.0)
    if hit is None or hit.component.entity not in env.objects[name]._objs:
        return None
    return float(start[2] + direction_z * hit.distance)


def _shifted(pose: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """`pose` moved by `offset` (x, y, z), turned the same way."""
    shifted = pose.copy()
    shifted[:3] += offset
    return shifted


def _rolled(pose: np.ndarray) -> np.ndarray:
    """The same TCP pose turned half a turn about the fingers' direction (the fingers swap sides)."""
    rolled = pose.copy()
    rolled[3:] = _matrix_to_quaternion(quat_to_matrix(pose[3:]) @ np.diag([-1.0, -1.0, 1.0]))
    return rolled


def _rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle).as_matrix()


def _above(env: RoboLabEnv, pose: np.ndarray, height: float, hanging: float, held: str | None = None) -> np.ndarray:
    """`pose` raised by `height`, and further if needed so that whatever hangs `hanging` metres below the TCP (the
    held object; else the fingertips) passes TRAVEL_CLEARANCE above every object (but `held`) within TRAVEL_RADIUS."""
    tops = [
        points[np.linalg.norm(points[:, :2] - pose[:2], axis=1) < TRAVEL_RADIUS, 2].max(initial=0.0)
        for points in (_world_points(env, name) for name in env.objects if name != held)
    ]
    raised = pose.copy()
    raised[2] = max(pose[2] + height, max(tops, default=0.0) + TRAVEL_CLEARANCE + max(hanging, FINGERTIP_BELOW_TCP))
    return raised


def _over_place(
    env: RoboLabEnv, place: np.ndarray, held_bottom: float, held: str, onto: str | None
) -> list[np.ndarray]:
    """Where the held object may be carried to before it is lowered straight to `place`, best first: as high as
    above a release just over the top of `onto` (the way in to a low release inside a bin is then as high as the
    way to one over its rim), then only APPROACH_HEIGHT above `place` (see `_above`) where that is lower."""
    low = _above(env, place, APPROACH_HEIGHT, hanging=held_bottom, held=held)
    if onto is None:
        return [low]
    high = low.copy()
    high[2] = max(low[2], _world_points(env, onto)[:, 2].max() + RELEASE_CLEARANCE + held_bottom + APPROACH_HEIGHT)
    if high[2] <= low[2] + 1e-3:
        return [low]
    # where that is out of reach: the held object's bottom just over the top of `onto` (a tall crate's walls, which
    # `_above` may not see where the crate has only its corners as points), before the lowest way in
    rim = low.copy()
    rim[2] = high[2] - APPROACH_HEIGHT + RELEASE_CLEARANCE
    return [high, rim, low] if rim[2] > low[2] + 1e-3 else [high, low]


def _pass_height(env: RoboLabEnv, start: np.ndarray, end: np.ndarray, name: str) -> float | None:
    """A TCP height from which the fingertips pass TRAVEL_CLEARANCE above every object but `name` near the
    straight way from TCP position `start` to `end` (within PASS_RADIUS of it, horizontally); None where that way
    itself clears them all (the height is then not needed)."""
    fractions = np.linspace(0.0, 1.0, PASS_SAMPLES)
    way = start[None, :] + fractions[:, None] * (end - start)[None, :]
    need, highest = -np.inf, -np.inf
    for other in env.objects:
        if other == name:
            continue
        points = _world_points(env, other)
        distance = np.linalg.norm(points[None, :, :2] - way[:, None, :2], axis=2)  # (samples, points)
        near = distance < PASS_RADIUS
        if not near.any():
            continue
        tops = np.where(near, points[None, :, 2], -np.inf).max(axis=1) + TRAVEL_CLEARANCE + FINGERTIP_BELOW_TCP
        need = max(need, float((tops - way[:, 2]).max()))
        highest = max(highest, float(tops.max()))
    if need <= 0.0:
        return None
    return max(highest, float(end[2]))


def _raised(pose: np.ndarray, height: float) -> np.ndarray:
    return _shifted(pose, np.array([0.0, 0.0, height]))


def _down_quaternion(closing_direction: np.ndarray, keep_sign: bool = False) -> np.ndarray:
    """Quaternion (w, x, y, z) of a TCP pointing down (its z = world -z) with its y axis (the fingers' closing
    direction) along `closing_direction` in the table plane; unless `keep_sign`, of the two ways round the one
    whose x axis points away from the robot."""
    y = np.array([closing_direction[0], closing_direction[1], 0.0])
    y /= np.linalg.norm(y)
    z = np.array([0.0, 0.0, -1.0])
    x = np.cross(y, z)
    if x[0] < 0 and not keep_sign:  # the hand's x away from the robot: the wrist does not have to turn around
        x, y = -x, -y
    return _matrix_to_quaternion(np.stack([x, y, z], axis=1))


def _matrix_to_quaternion(rotation: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    return np.array([w, x, y, z])


def _tilt(env: RoboLabEnv, name: str) -> float:
    """Angle (rad) between the object's up axis and world z."""
    env.eval_context.refresh()
    return float(np.arccos(np.clip(env.eval_context.up_axis(name)[0, 2].item(), -1.0, 1.0)))


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation matrix that turns direction `a` into direction `b`."""
    from scipy.spatial.transform import Rotation

    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    axis = np.cross(a, b)
    sine, cosine = np.linalg.norm(axis), float(np.dot(a, b))
    if sine < 1e-9:
        if cosine > 0:
            return np.eye(3)
        other = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        axis = np.cross(a, other)
        return Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.pi).as_matrix()
    return Rotation.from_rotvec(axis / sine * np.arctan2(sine, cosine)).as_matrix()


# ------------------------------------------------------------------------------------------------ front grasps
# An object on a shelf level with another level above it cannot be reached from above: the hand comes in from the
# open side, leaning out of the shelf, grasps, lifts it off the level a little and pulls it straight out.
FRONT_TILTS = (
    15.0,
    20.0,
    25.0,
    30.0,
    40.0,
    55.0,
    70.0,
)  # degrees from vertical that the hand leans out of a covered level, least first
FRONT_TURNS = (0.0, 20.0, -20.0, 40.0, -40.0)  # degrees the leaning direction turns away from the robot's direction
FRONT_INSET = 0.03  # m inside a long object's end nearest the open side where a leaning hand grasps it
FRONT_MARGIN = 0.008  # m kept between the hand and a fixture
FRONT_APPROACH = 0.08  # m the hand comes in along its own axis to a front grasp
FRONT_PAD_CLEARANCE = 0.001  # m between a leaning hand's lowest pad corner and the level under a thin object
FRONT_PAD_BITE = 0.003  # m the pads' lower edge reaches below a thin part's top, their lowest corner at most ...
FRONT_PAD_DIG = 0.005  # ... this far below the part's bottom (it rests a little above the level; the pad gives)
FRONT_LIFT = 0.015  # m an object is lifted off its level before it is pulled out
FRONT_PULL_STEP = 0.02  # m between the poses tried when pulling an object out of a shelf ...
FRONT_PULL_MAX = 0.4  # ... at most this far
FRONT_PLACE_RISE = 0.02  # m above the release that an object is slid in over a high shelf from the front ...
FRONT_PLACE_LEAVE = 0.05  # ... and the hand rises over the release before it leaves
COVER_SHARE = 0.5  # the share of an object's points under a shelf's board that makes it covered by it
PAD_HALF_WIDTH = 0.012  # m from the middle of a finger pad to its edge, across the fingers' plane
# The hand as solid boxes in the TCP frame (z toward the fingertips): half extent along the hand's x, half extent
# along the closing direction, and the span along z (the open fingers, the knuckles, the body and the wrist).
HAND_SOLIDS = ((0.014, 0.075, -0.053, 0.0), (0.037, 0.042, -0.155, -0.053), (0.06, 0.06, -0.32, -0.155))
HAND_SAMPLE = 0.01  # m between the points that sample the hand's solids


@dataclass(frozen=True)
class FrontGrasp:
    """A grasp reached from the open side of a shelf: the TCP pose, the pose it comes in from along its own axis,
    the pose outside the shelf (at the height of that one) from which the hand moves in, and the horizontal
    direction (unit x, y) in which the held object is pulled out."""

    pose: np.ndarray
    approach: np.ndarray
    entry: np.ndarray
    out: np.ndarray


def _fixture_boxes(env: RoboLabEnv) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
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


def _inside_boxes(points: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray, np.ndarray]], margin: float) -> bool:
    """Whether any of the world `points` (N, 3) lies within `margin` of one of the `boxes`."""
    return any(
        bool(np.any(np.all(np.abs((points - centre) @ rotation) <= half + margin, axis=1)))
        for rotation, centre, half in boxes
    )


def _hand_points(pose: np.ndarray) -> np.ndarray:
    """Points sampling the hand's solids (HAND_SOLIDS) at TCP pose [x, y, z, qw, qx, qy, qz], in the world (N, 3)."""
    local = []
    for half_x, half_y, z_from, z_to in HAND_SOLIDS:
        axes = [np.linspace(-h, h, max(2, int(np.ceil(2 * h / HAND_SAMPLE)) + 1)) for h in (half_x, half_y)]
        zs = np.linspace(z_from, z_to, max(2, int(np.ceil((z_to - z_from) / HAND_SAMPLE)) + 1))
        local.append(np.stack(np.meshgrid(*axes, zs), axis=-1).reshape(-1, 3))
    return np.concatenate(local) @ quat_to_matrix(pose[3:]).T + pose[:3]


def _hand_clear(pose: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> bool:
    """Whether the hand at TCP `pose` keeps FRONT_MARGIN from every fixture box."""
    return not _inside_boxes(_hand_points(pose), boxes, FRONT_MARGIN)


def covered(env: RoboLabEnv, name: str, boxes: list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None) -> bool:
    """Whether a fixture's piece (a shelf's upper level) lies over object `name` lower than a hand coming from
    above would need: within the object's footprint and less than the hand's length above its top."""
    boxes = _fixture_boxes(env) if boxes is None else boxes
    points = _world_points(env, name)
    return bool(_covers(points, boxes))


def _covers(
    points: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The fixture boxes over the object of world `points` (over at least COVER_SHARE of its points, seen from
    above: an object beside a shelf that reaches a little under it is not covered), less than the hand's length
    above its top."""
    high = points.max(axis=0)
    reach = -HAND_SOLIDS[-1][2]
    found = []
    for rotation, centre, half in boxes:
        extent = np.abs(rotation) @ half
        box_low = centre - extent
        local = (points - centre) @ rotation  # in the box's frame: under it where both horizontal axes are inside
        horizontal = [axis for axis in range(3) if abs(rotation[2, axis]) < 0.5]
        under = np.all(np.abs(local[:, horizontal]) <= half[horizontal], axis=1)
        over = under.mean() >= COVER_SHARE
        if over and high[2] <= box_low[2] < high[2] + reach:
            found.append((rotation, centre, half))
    return found


def _open_sides(points: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> list[np.ndarray]:
    """Horizontal directions (unit x, y) out of the shelf whose level covers the object of world `points`: the
    outward normals of the covering board's sides that face the robot, the side nearest the object first."""
    rotation, centre, half = _covers(points, boxes)[0]
    towards_robot = -points[:, :2].mean(axis=0) / np.linalg.norm(points[:, :2].mean(axis=0))
    sides = []
    for axis in range(2):
        normal = rotation[:2, axis] / np.linalg.norm(rotation[:2, axis])
        for sign in (1.0, -1.0):
            face = sign * normal
            if face @ towards_robot > 0.0:
                depth = float(centre[:2] @ face + half[axis] - (points[:, :2] @ face).max())
                sides.append((depth, face))
    return [face for _, face in sorted(sides, key=lambda item: item[0])]


def shelf_exit_spot(env: RoboLabEnv, name: str) -> np.ndarray:
    """Where (x, y) on the table an object taken off a covered shelf level is best put down: outside the shelf on
    the open side it is pulled out of, and to the side of the level's middle that it stands on, past the level's
    edge, so that it blocks neither its own way out nor that of anything else on the level."""
    points = _world_points(env, name)
    boxes = _fixture_boxes(env)
    rotation, centre, half = _covers(points, boxes)[0]
    out = _open_sides(points, boxes)[0]
    middle = (points.max(axis=0) + points.min(axis=0)) / 2
    size = points[:, :2].max(axis=0) - points[:, :2].min(axis=0)
    along = np.array([-out[1], out[0]])  # the open side's direction, horizontal
    extent = np.abs(rotation[:2]) @ half  # the board's half extents in the world's x and y ...
    out_reach, side_reach = abs(extent @ np.abs(out)), abs(extent @ np.abs(along))  # ... across and along the side
    out_room = float((centre[:2] - middle[:2]) @ out) + out_reach + np.abs(size) @ np.abs(out) / 2 + SPOT_MARGIN
    sign = 1.0 if float((middle[:2] - centre[:2]) @ along) >= 0.0 else -1.0
    side_room = float((centre[:2] - middle[:2]) @ along) + sign * (side_reach + np.abs(size) @ np.abs(along) / 2)
    return middle[:2] + out * out_room + along * side_room


def _leaning_rotation(closing: np.ndarray, lean: np.ndarray, tilt: float) -> np.ndarray:
    """The TCP rotation of a hand whose fingers close along horizontal `closing` and whose body leans `tilt` rad
    from vertical towards horizontal `lean` (the fingertips point down and away from it)."""
    y = np.array([closing[0], closing[1], 0.0]) / np.linalg.norm(closing[:2])
    z = np.array([-lean[0] * np.sin(tilt), -lean[1] * np.sin(tilt), -np.cos(tilt)])
    return np.stack([np.cross(y, z), y, z], axis=1)


def front_grasps(env: RoboLabEnv, name: str) -> list[FrontGrasp]:
    """Grasps of a covered object (see `covered`) by a hand that leans out of the shelf towards the robot, least
    leaning first, each with the hand clear of every fixture at the grasp, on its way in and on the way out. A
    standing container too wide for the fingers is held by its wall at the rim, on the side across the way out; a
    long object near its end on the open side; anything else across its middle."""
    env.eval_context.refresh()
    boxes = _fixture_boxes(env)
    points = _world_points(env, name)
    bottom, top = float(points[:, 2].min()), float(points[:, 2].max())
    sides = _open_sides(points, boxes)
    wall = env.eval_context.entries[name].is_container and _tilt(env, name) < STANDING_TILT
    rim = points[points[:, 2] > top - 0.01]
    rim_centre = (rim[:, :2].max(axis=0) + rim[:, :2].min(axis=0)) / 2
    radius = float(np.linalg.norm(rim[:, :2] - rim_centre, axis=1).max())
    found = []
    for tilt_deg in FRONT_TILTS:
        tilt = np.radians(tilt_deg)
        for turn, side_out in ((turn, side_out) for side_out in sides for turn in FRONT_TURNS):
            lean = _turned(side_out, turn)
            closing = np.array([-lean[1], lean[0]])
            candidates = []  # (TCP position, closing direction)
            if wall:
                for side in (closing, -closing):
                    walls = _wall_along(env, name, rim_centre, side, radius, top)
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
                drop = float(np.interp(width, PAD_DROP_WIDTHS, PAD_DROP))
                # the pads' lower edge leans with the hand: its lowest corner clear of the level, or (a thin part)
                # its middle FRONT_PAD_BITE below the part's top with the corner at most FRONT_PAD_DIG below its bottom
                part_top = float(points[near, 2].max())
                low = bottom + drop * np.cos(tilt) + PAD_HALF_WIDTH * np.sin(tilt) + FRONT_PAD_CLEARANCE
                bite = part_top - FRONT_PAD_BITE + drop * np.cos(tilt)
                if bite < low:
                    if low - bite > FRONT_PAD_DIG:
                        continue
                    low = bite
                z = max(part_top - GRASP_DEPTH, low)
                candidates.append((np.array([at[0], at[1], z]), closing))
            for position, side in candidates:
                rotation = _leaning_rotation(side, lean, tilt)
                pose = np.concatenate([position, _matrix_to_quaternion(rotation)])
                approach = _shifted(pose, -rotation[:, 2] * FRONT_APPROACH)
                if not (_hand_clear(pose, boxes) and _hand_clear(approach, boxes)):
                    continue
                if not _hand_clear(_raised(pose, FRONT_LIFT), boxes):
                    continue
                entry = _outside(approach, lean, boxes)
                if entry is not None:
                    found.append(FrontGrasp(pose, approach, entry, lean))
        if len(found) >= 4:
            break
    return found


def _outside(
    pose: np.ndarray,
    out: np.ndarray,
    boxes: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    held: np.ndarray | None = None,
) -> np.ndarray | None:
    """`pose` moved horizontally along `out` until the hand (and the `held` points, relative to the TCP) is outside
    the footprint of every fixture box, the hand clear of them all the way; None if it would hit one first."""
    tall = [(rotation, centre, half + np.array([0.0, 0.0, 1.0])) for rotation, centre, half in boxes]
    direction = np.array([out[0], out[1], 0.0])
    for distance in np.arange(0.0, FRONT_PULL_MAX + 1e-9, FRONT_PULL_STEP):
        moved = _shifted(pose, direction * distance)
        if not _hand_clear(moved, boxes):
            return None
        inside = _inside_boxes(_hand_points(moved), tall, FRONT_MARGIN)
        if not inside and (held is None or not _inside_boxes(held + moved[:3], tall, FRONT_MARGIN)):
            return moved
    return None


def pulled_out(env: RoboLabEnv, name: str, grasp: FrontGrasp) -> np.ndarray | None:
    """The TCP pose, FRONT_LIFT above `grasp` and moved along its way out, where the hand and object `name` held
    by it are outside every fixture's footprint; None if the hand would hit a fixture first."""
    held = _world_points(env, name) - grasp.pose[:3]
    return _outside(_raised(grasp.pose, FRONT_LIFT), grasp.out, _fixture_boxes(env), held)
