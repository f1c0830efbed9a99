"""The predicate registry: batched tests of the scene state for success conditions, subtasks and events.

A predicate takes an EvalContext, the names of the objects it is about, its reference objects (container, surface,
reference ...) and parameters, and returns a bool tensor (num_envs, num_objects): whether it holds for each object
in each environment. Group predicates (stacked, placed_in_container_in_order) give one answer per environment,
repeated for every object. Combining objects (`all` / `any` / `choose K`) and the flags `require_contact_with`
(the object touches the first reference object) and `require_gripper_detached` (no finger touches it) are applied
in one place, `per_object` / `combine`, so every predicate gets them.

Frames: world = robot frame, x forward, y left, z up. "In front of" means closer to the robot (-x).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import torch

from robolab_ms.scene import DIRECTIONS

if TYPE_CHECKING:
    from robolab_ms.tasks.condition import Condition
    from robolab_ms.tasks.context import EvalContext

PredicateFn = Callable[..., torch.Tensor]
CONTACT_FORCE_N = 0.1  # two bodies touch when the force between them exceeds this (RoboLab's threshold)
TABLE = "table"
STACK_ORDERS = ("none", "bottom_to_top", "top_to_bottom")


@dataclass(frozen=True)
class PredicateInfo:
    """A registered predicate: function, reference-object fields (name -> default, None = required), parameters."""

    name: str
    function: PredicateFn
    references: dict[str, str | None] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    group: bool = False
    doc: str = ""

    @property
    def contact_reference(self) -> str | None:
        """The reference field that `require_contact_with` refers to (the first one)."""
        return next(iter(self.references), None)


PREDICATES: dict[str, PredicateInfo] = {}
FLAGS = {"require_contact_with": False, "require_gripper_detached": False, "require_picked_up": False}
PICKED_UP_DISTANCE = 0.05  # m: require_picked_up asks for picked_up(object, table, distance=this) at some step


def predicate(
    name: str, references: dict[str, str | None] | None = None, group: bool = False, **params: Any
) -> Callable[[PredicateFn], PredicateFn]:
    """Register a predicate under `name`; `params` are its tunable parameters with their defaults."""

    def register(function: PredicateFn) -> PredicateFn:
        if name in PREDICATES:
            raise ValueError(f"predicate '{name}' is registered twice")
        doc = (function.__doc__ or "").strip()
        PREDICATES[name] = PredicateInfo(name, function, dict(references or {}), dict(params), group, doc)
        return function

    return register


def _each(objects: list[str], test: Callable[[str], torch.Tensor]) -> torch.Tensor:
    return torch.stack([test(name) for name in objects], dim=1)


def _broadcast(holds: torch.Tensor, objects: list[str]) -> torch.Tensor:
    return holds[:, None].expand(-1, len(objects))


# ------------------------------------------------------------------------------------------------ contact, grasp
@predicate("in_contact", references={"reference": None})
def in_contact(ctx: EvalContext, objects: list[str], reference: str) -> torch.Tensor:
    """The object and the reference push on each other with more than 0.1 N."""
    return _each(objects, lambda name: ctx.contact_force(name, reference) > CONTACT_FORCE_N)


@predicate("grasped")
def grasped(ctx: EvalContext, objects: list[str]) -> torch.Tensor:
    """A gripper finger touches the object (more than 0.1 N)."""
    return ctx.gripper_forces(objects) > CONTACT_FORCE_N


@predicate("released")
def released(ctx: EvalContext, objects: list[str]) -> torch.Tensor:
    """No gripper finger touches the object."""
    return ~grasped(ctx, objects)


@predicate("picked_up", references={"surface": TABLE}, distance=0.05)
def picked_up(ctx: EvalContext, objects: list[str], surface: str, distance: float) -> torch.Tensor:
    """Grasped, with every bounding-box corner at least `distance` (m) above the top of `surface`."""
    top = ctx.top_z(surface)
    lifted = _each(objects, lambda name: ctx.corners(name)[:, :, 2].amin(dim=1) >= top + distance)
    return lifted & grasped(ctx, objects)


# ------------------------------------------------------------------------------------------------ containers
def _inside_hull(ctx: EvalContext, objects: list[str], container: str, tolerance: float, open_top: bool):
    planes = ctx.container_planes(container, open_top)  # (P, 4), container frame
    centres = torch.stack([ctx.centre(name) for name in objects], dim=1)  # (E, O, 3)
    local = ctx.in_frame(centres, container)
    return ((local[..., None, :] * planes[:, :3]).sum(-1) + planes[:, 3] <= tolerance).all(dim=-1)


@predicate("in_container", references={"container": None}, tolerance=0.0, container_max_tilt=math.pi)
def in_container(
    ctx: EvalContext, objects: list[str], container: str, tolerance: float, container_max_tilt: float
) -> torch.Tensor:
    """The object's centre is inside the container's convex hull or the column above its rim (any orientation);
    `tolerance` (m) widens the hull. With `container_max_tilt` (rad) below pi, the container must also stand within
    that angle of upright: a bowl knocked over onto the object does not hold it."""
    holds = _inside_hull(ctx, objects, container, tolerance, open_top=True)
    if container_max_tilt < math.pi:
        holds = holds & upright(ctx, [container], container_max_tilt)
    return holds


@predicate("enclosed", references={"container": None}, tolerance=0.0)
def enclosed(ctx: EvalContext, objects: list[str], container: str, tolerance: float) -> torch.Tensor:
    """The object's centre is inside the container's closed convex hull (below the rim, not above it)."""
    return _inside_hull(ctx, objects, container, tolerance, open_top=False)


@predicate("outside_of", references={"container": None}, tolerance=0.0)
def outside_of(ctx: EvalContext, objects: list[str], container: str, tolerance: float) -> torch.Tensor:
    """The object is not in the container (nor in the column above it)."""
    return ~_inside_hull(ctx, objects, container, tolerance, open_top=True)


@predicate(
    "outside_of_and_on_surface", references={"container": None, "surface": TABLE}, tolerance=0.0, max_tilt=math.pi
)
def outside_of_and_on_surface(
    ctx: EvalContext, objects: list[str], container: str, surface: str, tolerance: float, max_tilt: float
) -> torch.Tensor:
    """Out of the container and resting on `surface` (in contact with it); with `max_tilt` (rad) below pi, also
    standing within that angle of upright: set down, not knocked over."""
    holds = outside_of(ctx, objects, container, tolerance) & in_contact(ctx, objects, surface)
    if max_tilt < math.pi:
        holds = holds & upright(ctx, objects, max_tilt)
    return holds


@predicate("placed_in_container_in_order", references={"container": None}, group=True, tolerance=0.0)
def placed_in_container_in_order(
    ctx: EvalContext, objects: list[str], container: str, tolerance: float
) -> torch.Tensor:
    """Every object has been placed (in the container, released) and the first placements came in list order."""
    placed = _inside_hull(ctx, objects, container, tolerance, open_top=True) & released(ctx, objects)
    first = ctx.memory(
        ("placed_order", container, tuple(objects)),
        lambda: torch.zeros(ctx.num_envs, len(objects), dtype=torch.long, device=ctx.device),
    )
    step = ctx.elapsed_steps[:, None].expand_as(first) + 1
    first.copy_(torch.where((first == 0) & placed, step, first))  # latch each object's first placement
    in_order = (
        (first[:, 1:] >= first[:, :-1]).all(dim=1)
        if len(objects) > 1
        else torch.ones_like(first[:, 0], dtype=torch.bool)
    )
    return _broadcast((first > 0).all(dim=1) & in_order & placed.all(dim=1), objects)


@predicate("groups_in_containers", groups={})
def groups_in_containers(ctx: EvalContext, objects: list[str], groups: dict[str, list[str]]) -> torch.Tensor:
    """Each object is in the container its group names (`groups`: container -> objects)."""
    home = {name: container for container, members in groups.items() for name in members}
    return _each(objects, lambda name: _inside_hull(ctx, [name], home[name], 0.0, open_top=True)[:, 0])


# ------------------------------------------------------------------------------------------------ surfaces, poses
@predicate("on_top", references={"reference": None}, margin=0.01, cone_deg=45.0)
def on_top(ctx: EvalContext, objects: list[str], reference: str, margin: float, cone_deg: float) -> torch.Tensor:
    """The reference pushes the object up (force >= 0.1 N within `cone_deg` of +z) and the object's centre is over
    the reference's footprint (widened by `margin` m)."""
    low, high = ctx.footprint(reference)
    cosine = math.cos(math.radians(cone_deg))

    def test(name: str) -> torch.Tensor:
        force = ctx.force_on(name, reference)
        size = torch.linalg.norm(force, dim=-1)
        upward = (size >= CONTACT_FORCE_N) & (force[:, 2] >= cosine * size)
        xy = ctx.centre(name)[:, :2]
        over = ((xy >= low - margin) & (xy <= high + margin)).all(dim=-1)
        return upward & over

    return _each(objects, test)


@predicate("upright", tolerance=0.1)
def upright(ctx: EvalContext, objects: list[str], tolerance: float) -> torch.Tensor:
    """The object's up axis is within `tolerance` (rad) of the world's."""
    return _each(objects, lambda name: ctx.up_axis(name)[:, 2] >= math.cos(tolerance))


@predicate("stationary", max_speed=0.01)
def stationary(ctx: EvalContext, objects: list[str], max_speed: float) -> torch.Tensor:
    """The object moves slower than `max_speed` (m/s)."""
    return _each(objects, lambda name: ctx.linear_speed(name) < max_speed)


@predicate("stacked", group=True, order="none", margin=0.01)
def stacked(ctx: EvalContext, objects: list[str], order: str, margin: float) -> torch.Tensor:
    """The objects form one stack: each consecutive pair touches, and the upper one is above the lower: higher, with
    its centre over the lower's footprint (widened by `margin` m), so one object leaning against another's side is
    no stack. `order`: none (any order), bottom_to_top (the list starts at the bottom) or top_to_bottom."""
    if order not in STACK_ORDERS:
        raise ValueError(f"stacked: order must be one of {', '.join(STACK_ORDERS)}, got {order!r}")
    heights = torch.stack([ctx.centre(name)[:, 2] for name in objects], dim=1)  # (E, O)
    touching = torch.stack(
        [
            torch.stack(
                [
                    ctx.contact_force(a, b) > CONTACT_FORCE_N
                    if a != b
                    else torch.zeros(ctx.num_envs, dtype=torch.bool, device=ctx.device)
                    for b in objects
                ],
                dim=1,
            )
            for a in objects
        ],
        dim=1,
    )  # (E, O, O)
    if order == "none":
        sequence = heights.argsort(dim=1)  # bottom first, per environment
    else:
        indices = torch.arange(len(objects), device=ctx.device)
        sequence = (indices if order == "bottom_to_top" else indices.flip(0)).expand(ctx.num_envs, -1)
    lower, upper = sequence[:, :-1], sequence[:, 1:]
    rows = torch.arange(ctx.num_envs, device=ctx.device)[:, None]
    centres = torch.stack([ctx.centre(name)[:, :2] for name in objects], dim=1)  # (E, O, 2)
    bounds = [ctx.footprint(name) for name in objects]
    low = torch.stack([bound[0] for bound in bounds], dim=1) - margin  # (E, O, 2)
    high = torch.stack([bound[1] for bound in bounds], dim=1) + margin
    upper_xy = centres[rows, upper]  # (E, O-1, 2)
    over = ((upper_xy >= low[rows, lower]) & (upper_xy <= high[rows, lower])).all(dim=-1)
    higher = heights.gather(1, upper) > heights.gather(1, lower)
    holds = (touching[rows, lower, upper] & higher & over).all(dim=1)
    return _broadcast(holds, objects)


# ------------------------------------------------------------------------------------------------ spatial relations
def _direction(axis: tuple[float, float]):
    def test(ctx: EvalContext, objects: list[str], reference: str, cone_deg: float, max_dz: float) -> torch.Tensor:
        cosine = math.cos(math.radians(cone_deg))
        towards = torch.tensor(axis, device=ctx.device)

        def one(name: str) -> torch.Tensor:
            offset = ctx.centre(name) - ctx.centre(reference)
            planar = torch.linalg.norm(offset[:, :2], dim=-1)
            aligned = (offset[:, :2] * towards).sum(-1) >= cosine * planar
            return aligned & (planar > 1e-6) & (offset[:, 2].abs() <= max_dz)

        return _each(objects, one)

    return test


_MEANINGS = {
    "left_of": "left of (+y)",
    "right_of": "right of (-y)",
    "in_front_of": "in front of (closer to the robot, -x)",
    "behind": "behind (farther from the robot, +x)",
}
for _name, _axis in DIRECTIONS.items():
    _meaning = _MEANINGS[_name]
    _function = _direction(_axis)
    _function.__doc__ = (
        f"The object is {_meaning} the reference, seen from the robot: the horizontal offset lies "
        "within `cone_deg` of that direction and the heights differ by at most `max_dz` (m)."
    )
    predicate(_name, references={"reference": None}, cone_deg=45.0, max_dz=0.1)(_function)


@predicate("next_to", references={"reference": None}, distance=0.05)
def next_to(ctx: EvalContext, objects: list[str], reference: str, distance: float) -> torch.Tensor:
    """The horizontal gap between the bounding boxes of object and reference is at most `distance` (m)."""
    ref_low, ref_high = ctx.footprint(reference)

    def one(name: str) -> torch.Tensor:
        low, high = ctx.footprint(name)
        gap = torch.clamp(torch.maximum(low - ref_high, ref_low - high), min=0.0)
        return torch.linalg.norm(gap, dim=-1) <= distance

    return _each(objects, one)


@predicate("on_center", references={"reference": None}, tolerance=0.03)
def on_center(ctx: EvalContext, objects: list[str], reference: str, tolerance: float) -> torch.Tensor:
    """The object's centre is within `tolerance` (m) of the reference's centre along x and along y."""
    return _each(objects, lambda name: ((ctx.centre(name) - ctx.centre(reference))[:, :2].abs() <= tolerance).all(-1))


# ------------------------------------------------------------------------------------------------ conditions
def per_object(ctx: EvalContext, condition: Condition) -> torch.Tensor:
    """The condition's predicate with its flags applied, per object: bool (num_envs, num_objects). Cached per step."""
    return ctx.cached(("condition", id(condition)), lambda: _per_object(ctx, condition))


def _per_object(ctx: EvalContext, condition: Condition) -> torch.Tensor:
    info = PREDICATES[condition.predicate]
    objects = list(condition.objects)
    holds = info.function(ctx, objects, **condition.references, **condition.params)
    contact_with = condition.references.get(info.contact_reference) if info.contact_reference else None
    if condition.require_contact_with and contact_with is not None:
        holds = holds & in_contact(ctx, objects, contact_with)
    if condition.require_gripper_detached:
        holds = holds & released(ctx, objects)
    if condition.require_picked_up:
        holds = holds & was_picked_up(ctx, objects)
    return holds


def was_picked_up(ctx: EvalContext, objects: list[str]) -> torch.Tensor:
    """Whether each object has been picked up off the table at some step of this episode so far: `picked_up`
    (PICKED_UP_DISTANCE) while nothing but the robot touched it, so the robot alone held it up. It was set down by
    the robot, not knocked or swept there, nor flung up by a blow or lifted on something the arm tipped while a
    finger brushed it."""
    lifted = picked_up(ctx, objects, TABLE, PICKED_UP_DISTANCE)
    if bool(lifted.any()):  # the contact pass only when a finger touches an object well above the table
        lifted = lifted & (ctx.non_robot_forces(objects) <= CONTACT_FORCE_N)
    seen = ctx.memory(
        ("picked_up_once", tuple(objects)),
        lambda: torch.zeros(ctx.num_envs, len(objects), dtype=torch.bool, device=ctx.device),
    )
    seen |= lifted
    return seen.clone()


def combine(holds: torch.Tensor, logical: str, k: int) -> torch.Tensor:
    """Reduce per-object truth (num_envs, num_objects) by `all`, `any` or `choose` (exactly k)."""
    if logical == "all":
        return holds.all(dim=1)
    if logical == "any":
        return holds.any(dim=1)
    return holds.sum(dim=1) == k


def evaluate_condition(ctx: EvalContext, condition: Condition) -> torch.Tensor:
    """Whether a whole condition holds: bool (num_envs,)."""
    return combine(per_object(ctx, condition), condition.logical, condition.k)
