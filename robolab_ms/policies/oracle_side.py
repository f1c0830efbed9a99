"""The oracle's side hold of a long tool by the part of its handle that reaches out of the container it lies in
(hammers side by side in a bin, millimetres apart, their handles over the bin's front wall).

A top-down hold across a packed handle lands a finger on the neighbour, and the head at the back of the bin may be
out of reach from above. Where the handle (the tool's longest thin box-shaped collision part) reaches out over the
container's wall, the hand comes in level from a side of the handle where no other object lies, its fingers open
above and below the handle and closing across it in the vertical plane through the handle's axis. A tool walled in
on both sides waits until a neighbour has been taken away. The hand comes down beside the handle from the height
the tool will be lifted to (so that the arm is posed to lift it straight back up), the tool is lifted in straight
steps until it would clear the container hanging straight down from the grip, carried level, lowered and let go,
and the hand backs out the way it came.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.catalog.procedural import quat_to_matrix

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv
    from robolab_ms.policies.oracle import Job, OraclePolicy


HANDLE_RATIO = 4.0  # a handle is a box this many times as long as its thickest cross-section ...
HANDLE_THICKNESS = 0.04  # ... and no thicker than this (m), so that the open fingers close across it
PACKED_GAP = 0.01  # m: a neighbour this close beside the handle (any way along it) blocks that side
OVERHANG_MIN = 0.06  # m of the handle (along it) that must reach out of the container's footprint
WALL_MARGIN = 0.03  # m (along the handle) the grip stays out from the container's wall ...
END_MARGIN = 0.025  # ... and in from the handle's end
SIDE_REACH = 0.09  # m beside the handle (level, across it) the hand needs free of other objects ...
SIDE_HEIGHT = 0.04  # ... within this far above or below the handle's axis ...
SIDE_ALONG = 0.04  # ... and this far either way along it
GRIP_PAST = -0.004  # m the TCP goes past the handle's axis (short: the fingertips, 1 cm on, stay off a neighbour)
APPROACH_DISTANCES = (0.10, 0.07, 0.05)  # m from the grip, level across the handle, where the hand starts in
LIFT_CLEARANCE = 0.03  # m the held tool, hanging straight down from the grip, is lifted above the container
LIFT_MIN = 0.15  # m the held tool is lifted at least
BACK_OUT = 0.08  # m the hand backs out along its approach after letting go


def _handle(env: RoboLabEnv, name: str) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """The handle of object `name`: (its free end, the unit vector from there along it towards the rest of the
    tool, its length, its radius (half the thickest cross-section)), in the robot frame; None where the object
    has no box collision part that is long and thin enough (a mesh tool, a block)."""
    from robolab_ms.policies.oracle import _mass_centre

    actor = env.objects[name]
    best = None
    for shape in actor._bodies[0].get_collision_shapes():
        half = getattr(shape, "half_size", None)
        if half is None:
            continue
        half = np.asarray(half, dtype=float)
        axis = int(np.argmax(half))
        thick = float(np.delete(half, axis).max())
        if half[axis] < HANDLE_RATIO * thick or 2 * thick > HANDLE_THICKNESS:
            continue
        if best is None or half[axis] > best[2][best[1]]:
            best = (shape, axis, half)
    if best is None:
        return None
    shape, axis, half = best
    pose = actor.pose.sp * shape.local_pose
    direction = quat_to_matrix(np.asarray(pose.q))[:, axis]
    centre = np.asarray(pose.p, dtype=float)
    if float((_mass_centre(env, name) - centre) @ direction) < 0:  # from the free end towards the tool's mass
        direction = -direction
    length = 2 * float(half[axis])
    return centre - direction * half[axis], direction, length, float(np.delete(half, axis).max())


def _container_below(env: RoboLabEnv, name: str) -> str | None:
    """The container whose footprint holds object `name`'s centre of mass, if any."""
    from robolab_ms.policies.oracle import _mass_centre, _world_points

    centre = _mass_centre(env, name)
    for other in env.objects:
        if other == name or not env.eval_context.entries[other].is_container:
            continue
        points = _world_points(env, other)
        if np.all(points[:, :2].min(axis=0) <= centre[:2]) and np.all(centre[:2] <= points[:, :2].max(axis=0)):
            return other
    return None


SAMPLE_STEP = 0.01  # m between the points sampled through a box collision part


def _solid_points(env: RoboLabEnv, name: str) -> np.ndarray:
    """Points of object `name` in the robot frame (N, 3): its surface points, and a grid SAMPLE_STEP apart through
    each of its box collision parts (a procedural object's surface points may be only its corners)."""
    from robolab_ms.policies.oracle import _dense_world_points

    pieces = [_dense_world_points(env, name)]
    actor = env.objects[name]
    for shape in actor._bodies[0].get_collision_shapes():
        half = getattr(shape, "half_size", None)
        if half is None:
            continue
        axes = [np.linspace(-h, h, max(2, int(np.ceil(2 * h / SAMPLE_STEP)) + 1)) for h in np.asarray(half, float)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        pose = actor.pose.sp * shape.local_pose
        pieces.append(grid @ quat_to_matrix(np.asarray(pose.q)).T + np.asarray(pose.p))
    return np.concatenate(pieces)


def _others_near(env: RoboLabEnv, name: str, skip: str | None) -> np.ndarray:
    """Points of every object but `name` and `skip` (the container), in the robot frame (N, 3)."""
    pieces = [_solid_points(env, other) for other in env.objects if other not in (name, skip)]
    return np.concatenate(pieces) if pieces else np.zeros((0, 3))


def side_grips(env: RoboLabEnv, name: str, fits: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
    """Side holds of long tool `name` by its handle where it lies in a container with its handle reaching
    OVERHANG_MIN out over the wall: (TCP grasp pose [x, y, z, qw, qx, qy, qz], the unit approach direction, level),
    nearest the tool's middle first, from a side of the handle where no other object lies within reach of the hand
    (packed neighbours); empty where the tool does not lie so or both sides are taken. With `fits`, one dummy entry
    where the tool lies so, whatever is beside it."""
    from robolab_ms.policies.oracle import _matrix_to_quaternion, _world_points

    handle = _handle(env, name)
    container = _container_below(env, name)
    if handle is None or container is None:
        return []
    end, direction, length, radius = handle
    if abs(direction[2]) > 0.7:  # a handle standing up: not this hold
        return []
    box = _world_points(env, container)
    low, high = box[:, :2].min(axis=0), box[:, :2].max(axis=0)
    ts = np.linspace(0.0, length, 60)
    axis_points = end + ts[:, None] * direction
    outside = ~np.all((axis_points[:, :2] >= low) & (axis_points[:, :2] <= high), axis=1)
    inside_at = np.flatnonzero(~outside)
    overhang = float(ts[inside_at[0]]) if len(inside_at) else length
    if overhang < OVERHANG_MIN:
        return []
    if fits:  # only whether the tool lies so, whatever is beside its handle
        return [(np.zeros(7), np.zeros(3))]
    others = _others_near(env, name, container)
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
            blocked = near_hand | beside
            if np.any(blocked):
                continue
            x_axis = np.cross(closing, approach)
            rotation = np.stack([x_axis, closing, approach], axis=1)
            grasp = np.concatenate([point + approach * GRIP_PAST, _matrix_to_quaternion(rotation)])
            grips.append((grasp, approach))
    return grips


def side_hold_job(policy: OraclePolicy, job: Job) -> bool:
    """Plan `job` (onto the table or into a container) with a side hold of its object's handle, where the object
    is a long tool in a container with its handle reaching out (`side_grips`); where both sides of it are taken,
    the first later job whose object has a free side is planned instead and `job` goes to the back of the queue.
    Whether a job was planned; the next of the holds comes first each time the job is planned again."""
    from robolab_ms.policies.oracle import OracleFailure

    env = policy.env
    if job.at is None and job.onto is None:
        return False
    grips = side_grips(env, job.obj)
    if not grips and side_grips(env, job.obj, fits=True):  # walled in on both sides: first one that is not
        later = next((other for other in policy.jobs if side_grips(env, other.obj)), None)
        if later is not None:
            policy.jobs.remove(later)
            policy.jobs.append(job)
            policy._job = later
            try:
                return _side_hold(policy, later, side_grips(env, later.obj))
            except OracleFailure:  # the caller queues `job` again; `later` waits its turn, its retries unused
                policy.jobs.remove(job)
                policy.jobs.append(later)
                raise
    if not grips:
        return False
    return _side_hold(policy, job, grips)


def _side_hold(policy: OraclePolicy, job: Job, grips: list[tuple[np.ndarray, np.ndarray]]) -> bool:
    """Plan `job` with the first of `grips` (side holds, `side_grips`) that has a motion plan, starting after the
    holds its earlier plans used; True, or OracleFailure where none has."""
    from robolab_ms.policies.oracle import OracleFailure

    tried = policy._grasps.setdefault(job.obj, [])
    first = min(len(tried), len(grips) - 1)
    for grasp, approach in grips[first:] + grips[:first]:  # the next hold each time the job is planned again
        planned = len(policy.actions)
        try:
            _plan_side_hold(policy, job, grasp, approach)
        except OracleFailure:
            while len(policy.actions) > planned:
                policy.actions.pop()
            continue
        tried.append(grasp)
        return True
    tried.append(grips[first][0])
    raise OracleFailure(f"cannot hold '{job.obj}' by its handle from the side: no motion plan for any hold")


def _plan_side_hold(policy: OraclePolicy, job: Job, grasp: np.ndarray, approach: np.ndarray) -> None:
    """Queue the moves of `job` with its object held at TCP pose `grasp`, the hand coming in along `approach`."""
    from robolab_ms.policies.oracle import (
        GRIPPER_STEPS,
        OracleFailure,
        _centre,
        _world_points,
        object_bottom,
        place_pose,
    )

    env = policy.env
    held_bottom = grasp[2] - object_bottom(env, job.obj)
    held_offset = grasp[:2] - _centre(env, job.obj)[:2]
    place, _ = place_pose(env, job, grasp, held_bottom, held_offset)
    container = _container_below(env, job.obj)
    rim = float(_world_points(env, container)[:, 2].max()) if container is not None else 0.0
    lifted = grasp.copy()
    hanging = float(np.linalg.norm(_world_points(env, job.obj) - grasp[:3], axis=1).max())  # should it swing down
    lifted[2] = max(grasp[2] + LIFT_MIN, rim + LIFT_CLEARANCE + hanging)
    qpos = policy._planner_qpos()
    for distance in APPROACH_DISTANCES:
        start = grasp.copy()
        start[:3] -= approach * distance
        high = start.copy()
        high[2] = lifted[2]
        planned = len(policy.actions)
        try:  # down from the height of the lift, so that the arm is posed to lift the tool straight back up
            qpos = policy._move(qpos, high, f"reach above beside the handle of '{job.obj}'", straight=False)
            qpos, _ = _rise(policy, qpos, high, start[2], f"reach beside the handle of '{job.obj}'")
            break
        except OracleFailure:
            while len(policy.actions) > planned:
                policy.actions.pop()
        try:
            qpos = policy._move(qpos, start, f"reach beside the handle of '{job.obj}'", straight=False)
            break
        except OracleFailure:
            if distance == APPROACH_DISTANCES[-1]:
                raise
    qpos = policy._move_straight(qpos, grasp, f"move in around the handle of '{job.obj}'")
    policy._hold(qpos, 1.0, GRIPPER_STEPS)
    qpos, lifted = _rise(policy, qpos, grasp, lifted[2], f"lift '{job.obj}' by its handle")
    way = lifted.copy()
    way[:2] = place[:2]
    try:
        qpos = policy._move_straight(qpos, way, f"carry '{job.obj}' by its handle")
    except OracleFailure:
        qpos = policy._move(qpos, way, f"carry '{job.obj}' by its handle")
    qpos, _ = _rise(policy, qpos, way, place[2], f"lower '{job.obj}'")
    policy._hold(qpos, 0.0, GRIPPER_STEPS)
    back = place.copy()
    back[:3] -= approach * BACK_OUT
    try:
        qpos = policy._move_straight(qpos, back, f"back out from '{job.obj}'")
    except OracleFailure:
        pass
    up = back.copy()
    up[2] += 0.05
    try:
        policy._move(qpos, up, f"retreat from '{job.obj}'")
    except OracleFailure:
        pass
    return True


RISE_STEP = 0.04  # m per straight move of a lift
MAX_SWING = 0.6  # rad a joint may turn in a lift's step that is not a straight move, once it has risen LIFT_MIN


def _rise(
    policy: OraclePolicy, qpos: np.ndarray, pose: np.ndarray, height: float, what: str
) -> tuple[np.ndarray, np.ndarray]:
    """Queue a move of the TCP from `pose` straight up or down to `height`, in steps of RISE_STEP (each a straight
    move where one is found, else any move to it; a lift stops short where it has risen LIFT_MIN and the next step
    would swing a joint by more than MAX_SWING); returns the final joints and TCP pose."""
    from robolab_ms.policies.oracle import OracleFailure

    step, sign = pose.copy(), 1.0 if height >= pose[2] else -1.0
    while sign * (height - step[2]) > 1e-6:
        previous, step = step, step.copy()
        step[2] = step[2] + sign * min(RISE_STEP, sign * (height - step[2]))
        try:
            qpos = policy._move_straight(qpos, step, what)
        except OracleFailure:
            planned = len(policy.actions)
            moved = policy._move(qpos, step, what)
            if sign > 0 and previous[2] - pose[2] >= LIFT_MIN and np.abs(moved[:7] - qpos[:7]).max() > MAX_SWING:
                while len(policy.actions) > planned:  # high enough: no swing of the arm to go higher
                    policy.actions.pop()
                return qpos, previous
            qpos = moved
    return qpos, step
