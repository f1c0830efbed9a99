"""The predicate registry: batched tests of the scene state used by success conditions and subtasks.

A predicate takes an EvalContext, the names of the objects it is about and (for most) a reference object, and
returns a bool tensor of shape (num_envs, num_objects): whether it holds for each object in each environment.
Combining objects (`all` / `any` / `choose K`) and the flags `require_contact_with` and `require_gripper_detached`
are applied in one place, `evaluate_condition`, so every predicate gets them for free.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import torch

if TYPE_CHECKING:
    from robolab_ms.tasks.context import EvalContext
    from robolab_ms.tasks.spec import Condition

PredicateFn = Callable[..., torch.Tensor]
CONTACT_FORCE_N = 0.1  # two bodies touch when the force between them exceeds this (RoboLab's threshold)


@dataclass(frozen=True)
class PredicateInfo:
    """A registered predicate: its function, the name of its reference-object field (or None) and its parameters."""

    name: str
    function: PredicateFn
    reference: str | None
    params: dict[str, Any] = field(default_factory=dict)
    doc: str = ""


PREDICATES: dict[str, PredicateInfo] = {}
FLAGS = {"require_contact_with": False, "require_gripper_detached": False}


def predicate(name: str, reference: str | None = None, **params: Any) -> Callable[[PredicateFn], PredicateFn]:
    """Register a predicate under `name`; `params` are its tunable parameters with their defaults."""

    def register(function: PredicateFn) -> PredicateFn:
        if name in PREDICATES:
            raise ValueError(f"predicate '{name}' is registered twice")
        PREDICATES[name] = PredicateInfo(name, function, reference, dict(params), (function.__doc__ or "").strip())
        return function

    return register


@predicate("in_container", reference="container")
def in_container(ctx: EvalContext, objects: list[str], container: str) -> torch.Tensor:
    """The object's centre lies inside the container's convex hull, the column above its rim included."""
    planes = ctx.container_planes(container)  # (P, 4): n . x + d <= 0 inside, in the container frame
    centres = torch.stack([ctx.centre_in_frame(name, container) for name in objects], dim=1)  # (E, O, 3)
    distances = centres @ planes[:, :3].T + planes[:, 3]  # (E, O, P)
    return (distances <= 1e-4).all(dim=-1)


@predicate("grasped")
def grasped(ctx: EvalContext, objects: list[str]) -> torch.Tensor:
    """The object touches a gripper finger."""
    return torch.stack([ctx.touches_gripper(name) for name in objects], dim=1)


@predicate("released")
def released(ctx: EvalContext, objects: list[str]) -> torch.Tensor:
    """The object touches no gripper finger."""
    return ~grasped(ctx, objects)


@predicate("in_contact", reference="reference")
def in_contact(ctx: EvalContext, objects: list[str], reference: str) -> torch.Tensor:
    """The object and the reference push on each other with more than 0.1 N."""
    return torch.stack([ctx.contact_force(name, reference) > CONTACT_FORCE_N for name in objects], dim=1)


def per_object(ctx: EvalContext, condition: Condition, objects: list[str] | None = None) -> torch.Tensor:
    """The condition's predicate with its flags applied, per object: bool (num_envs, num_objects)."""
    info = PREDICATES[condition.predicate]
    objects = list(condition.objects) if objects is None else objects
    args = {info.reference: condition.reference} if info.reference else {}
    holds = info.function(ctx, objects, **args, **condition.params)
    if condition.require_contact_with and condition.reference is not None:
        holds = holds & in_contact(ctx, objects, condition.reference)
    if condition.require_gripper_detached:
        holds = holds & released(ctx, objects)
    return holds


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
