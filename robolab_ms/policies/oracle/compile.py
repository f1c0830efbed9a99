"""From a task's success condition to the oracle's jobs: which object to move, and where."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.places import (
    DIRECTIONS,
    free_spot,
    in_safe_area,
    shelf_exit_spot,
    spot_beside,
    standing_spot,
)
from robolab_ms.policies.oracle.world import (
    centre,
    covered,
    fixture_boxes,
    leaning_board,
    lying_container,
    open_side_depths,
    tilt,
    world_points,
)
from robolab_ms.tasks.predicates import PREDICATES, per_object

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

RESTING_GAP = 0.01  # m between one object's bottom and another's top within which the first rests on the second
LIFT_EXTRA = 0.05  # m an object is lifted beyond the distance a `picked_up` condition asks for


@dataclass(frozen=True)
class Job:
    """Move one object: onto or into the object `onto`, onto the table with the middle of its footprint at `at`
    (x, y), up by `lift` metres, or stand it upright where it lies (`upright`). Onto an object: at a free flat
    spot of it (a bin's floor, a plate), or at its middle when `centred` (stacking). A job onto an object that is
    also `upright` stands its (lying) object up first where it can."""

    obj: str
    onto: str | None = None
    centred: bool = False
    at: tuple[float, float] | None = None
    lift: float = 0.0
    upright: bool = False


# The predicates jobs_for turns into jobs (of a task's first success condition).
SOLVABLE_PREDICATES = ("in_container", "enclosed", "on_top", "on_center", "placed_in_container_in_order",
                       "groups_in_containers", "stacked", "picked_up", *DIRECTIONS, "next_to", "upright", "outside_of",
                       "outside_of_and_on_surface")  # fmt: skip


def jobs_for(env: RoboLabEnv) -> list[Job]:
    """The pick-and-place jobs that satisfy the task's first success condition."""
    condition = env.task_spec.success[0]
    return jobs_moving(env, list(condition.objects)[: condition.required_count])


def spare_jobs(env: RoboLabEnv) -> list[Job]:
    """Where the task's first success condition asks for any one or any k of its objects: a job for each object
    that `jobs_for` leaves out, to take the place of a job that cannot be done; else none."""
    condition = env.task_spec.success[0]
    spares = list(condition.objects)[condition.required_count :]
    return [job for name in spares for job in jobs_moving(env, [name])]


def jobs_moving(env: RoboLabEnv, objects: list[str]) -> list[Job]:
    """The jobs that bring `objects` (of the task's first success condition) to where the condition wants them."""
    condition = env.task_spec.success[0]
    predicate, references, params = condition.predicate, condition.references, condition.params
    if predicate in ("in_container", "enclosed", "on_top", "on_center", "placed_in_container_in_order"):
        reference = next(iter(references.values()))
        if predicate in ("on_top", "on_center") and condition.logical == "all" and len(objects) > 2:
            objects = largest_first(env, objects)  # all of many onto a plate: the last, largest one finds no room
        return [Job(name, onto=reference, upright=lying_container(env, name)) for name in objects]
    if predicate == "groups_in_containers":
        home = {name: container for container, members in params["groups"].items() for name in members}
        return [Job(name, onto=home[name]) for name in objects]
    if predicate == "stacked":
        order = objects[::-1] if params.get("order") == "top_to_bottom" else objects
        return [Job(upper, onto=lower, centred=True) for lower, upper in zip(order, order[1:])]
    if predicate == "picked_up":
        return [Job(name, lift=params.get("distance", 0.05) + LIFT_EXTRA) for name in objects[:1]]
    if predicate in DIRECTIONS or predicate == "next_to":
        at = spot_beside(env, references["reference"], predicate)
        return [Job(name, at=at) for name in objects[:1]]
    if predicate == "upright":
        tolerance = params.get("tolerance", 0.1)
        return [Job(name, upright=True) for name in objects if tilt(env, name) > tolerance]
    if predicate in ("outside_of", "outside_of_and_on_surface"):
        env.eval_context.refresh()
        objects = top_first(env, objects)  # a stack is taken apart from the top
        objects = way_out_first(env, objects)  # on a shelf level, the one in front before the one behind it
        footprints: list[np.ndarray] = []
        for name in objects:  # an object taken off a shelf level goes down near where it is, not behind the shelf
            near = shelf_exit_spot(env, name) if not env.scene.gpu_sim_enabled and covered(env, name) else None
            if near is not None and not in_safe_area(near):
                near = centre(env, name)[:2]  # no room beside the shelf (a long object): near where it lies
            moved = objects[: len(footprints) + 1]  # those not yet moved still stand where they are
            board = leaning_board(env, name)
            if board is not None:  # stood on its end beside its container, then laid down away from it
                footprints.append(standing_spot(env, name, board, taken=footprints).box)
                continue
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


def largest_first(env: RoboLabEnv, objects: list[str]) -> list[str]:
    """`objects` by the area of their footprint (x, y box as they lie now), largest first; equal ones keep their
    order."""
    areas = {name: float(np.prod(np.ptp(world_points(env, name)[:, :2], axis=0))) for name in objects}
    return sorted(objects, key=lambda name: -areas[name])


def way_out_first(env: RoboLabEnv, objects: list[str]) -> list[str]:
    """`objects` in their order, except that those under a shelf level (see `world.covered`) swap places among
    themselves to come nearest the level's open side first: one in front stands in the way of the hand reaching for
    one behind it. Equal ones keep their order."""
    boxes = fixture_boxes(env)
    depths = {
        name: open_side_depths(world_points(env, name), boxes)[0][0] for name in objects if covered(env, name, boxes)
    }
    slots = [index for index, name in enumerate(objects) if name in depths]
    ordered = list(objects)
    for index, name in zip(slots, sorted((objects[index] for index in slots), key=lambda name: depths[name])):
        ordered[index] = name
    return ordered


def top_first(env: RoboLabEnv, objects: list[str]) -> list[str]:
    """`objects` in their order, except that one resting on another of them (its bottom within RESTING_GAP of the
    other's top, their footprints overlapping) comes before it."""
    boxes = {name: (world_points(env, name).min(axis=0), world_points(env, name).max(axis=0)) for name in objects}

    def rests_on(upper: str, lower: str) -> bool:
        (low_u, high_u), (low_l, high_l) = boxes[upper], boxes[lower]
        overlap = bool(np.all(low_u[:2] < high_l[:2]) and np.all(low_l[:2] < high_u[:2]))
        return overlap and abs(low_u[2] - high_l[2]) < RESTING_GAP

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
