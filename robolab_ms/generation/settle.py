"""The physics check of a generated scene, and which requested relations hold once it has settled.

The scene is built as every episode builds it (RoboLabSceneBuilder, the jitter off) and the simulation runs 300
physics steps with the arm still: an object that moves more than 2 cm makes the scene unstable, the criterion of
`robolab validate` (robolab_ms.eval.validate). With `jittered_seeds`, the same check runs again on the jittered
layouts of the episodes with those first seeds, the layouts validation starts from: an object that rests on the
edge of its stability (a round stick that starts to roll) can hold still at its nominal place and move at another. Relations are then judged by the task predicates
(robolab_ms.tasks.predicates: left_of ..., next_to, on_top, in_container, stacked) on the settled state, and by
geometry for what no predicate covers (a place on the table, alignment, facing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from robolab_ms.catalog import Catalog
from robolab_ms.eval.validate import FELL_BELOW_M
from robolab_ms.generation.proposal import ROBOT, Relation
from robolab_ms.physics import MAX_DRIFT_M, STABILITY_PHYSICS_STEPS
from robolab_ms.scene import DIRECTIONS, SceneSpec

PLACE_TOLERANCE = 0.03  # m: an object asked for at (x, y) counts as there within this
ALIGN_TOLERANCE = 0.02  # m
FACING_TOLERANCE_DEG = 20.0


@dataclass
class SettleResult:
    """Drift of every object over the settle (m), whether all stayed within MAX_DRIFT_M, the objects that fell off
    the table, and for each list of relations judged (by the list's key) whether each holds afterwards."""

    drift: dict[str, float] = field(default_factory=dict)
    fallen: list[str] = field(default_factory=list)
    holds: dict[str, list[bool]] = field(default_factory=dict)

    @property
    def stable(self) -> bool:
        return all(value <= MAX_DRIFT_M for value in self.drift.values())

    def moved(self) -> dict[str, float]:
        """The objects that moved more than MAX_DRIFT_M, with their drift (m)."""
        return {name: value for name, value in self.drift.items() if value > MAX_DRIFT_M}


def settle(
    spec: SceneSpec, relations: dict[str, list[Relation]], catalog: Catalog, jittered_seeds: int = 0
) -> SettleResult:
    """Build the scene at its nominal layout, run STABILITY_PHYSICS_STEPS physics steps, judge each list of
    relations (for example "requested" and "answer"); the drift counts the jittered layouts of episode seeds
    0 .. jittered_seeds - 1 too."""
    from robolab_ms.scene.builder import table_entry
    from robolab_ms.scene.scene_env import SceneOnlyEnv
    from robolab_ms.tasks.context import EvalContext

    env = SceneOnlyEnv(replace(spec, jitter_xy=0.0, jitter_yaw=0.0), sim_backend="cpu", render_backend="cpu")
    try:
        env.reset(seed=0)
        objects = env.builder.objects
        start = {name: actor.pose.p[0].clone() for name, actor in objects.items()}
        for _ in range(STABILITY_PHYSICS_STEPS):
            env.scene.step()
        result = SettleResult()
        for name, actor in objects.items():
            result.drift[name] = float((actor.pose.p[0] - start[name]).norm())
        entries = {placement.name: catalog[placement.asset] for placement in spec.objects}
        entries["table"] = table_entry(spec)
        context = EvalContext(env.scene, {**objects, "table": env.builder.table}, entries, [], env.device)
        context.refresh()
        for name in objects:
            if float(context.centre(name)[0, 2]) < FELL_BELOW_M:
                result.fallen.append(name)
        for key, judged in relations.items():
            result.holds[key] = [relation_holds(context, relation, set(objects)) for relation in judged]
    finally:
        env.close()
    if jittered_seeds > 0 and spec.objects:
        for name, drift in jittered_drift(spec, jittered_seeds).items():
            result.drift[name] = max(result.drift.get(name, 0.0), drift)
    return result


def jittered_drift(spec: SceneSpec, seeds: int) -> dict[str, float]:
    """The largest drift (m) of each object over STABILITY_PHYSICS_STEPS physics steps from the jittered layouts
    of episode seeds 0 .. seeds - 1."""
    from robolab_ms.scene.scene_env import SceneOnlyEnv

    env = SceneOnlyEnv(spec, sim_backend="cpu", render_backend="cpu")
    drift: dict[str, float] = {}
    try:
        for seed in range(seeds):
            env.reset(seed=seed)
            objects = env.builder.objects
            start = {name: actor.pose.p[0].clone() for name, actor in objects.items()}
            for _ in range(STABILITY_PHYSICS_STEPS):
                env.scene.step()
            for name, actor in objects.items():
                drift[name] = max(drift.get(name, 0.0), float((actor.pose.p[0] - start[name]).norm()))
    finally:
        env.close()
    return drift


def relation_holds(context, relation: Relation, present: set[str]) -> bool:
    """Whether a requested relation holds in the (settled) state `context` reads; False when an object it names is
    not in the scene."""
    from robolab_ms.tasks.predicates import PREDICATES

    names = [*relation.objects, *([relation.reference] if relation.reference not in (None, ROBOT) else [])]
    if any(name not in present for name in names):
        return False
    if relation.kind in ("random_yaw", "anywhere"):
        return True

    def predicate(name: str, objects: list[str], **references: str) -> bool:
        info = PREDICATES[name]
        return bool(info.function(context, objects, **references, **info.params).all())

    subject, reference = relation.subject, relation.reference
    centre = context.centre(subject)[0].cpu().numpy()
    if relation.kind == "on_table":
        position = context.position(subject)[0].cpu().numpy()
        lowest = float(context.corners(subject)[0, :, 2].min())
        return bool(
            math.hypot(position[0] - relation.x, position[1] - relation.y) <= PLACE_TOLERANCE and lowest <= 0.01
        )
    if relation.kind in DIRECTIONS:
        holds = predicate(relation.kind, [subject], reference=reference)
        if holds and relation.distance is not None:
            other = context.centre(reference)[0].cpu().numpy()
            distance = float(np.linalg.norm((centre - other)[:2]))
            holds = abs(distance - relation.distance) <= max(PLACE_TOLERANCE, 0.25 * relation.distance)
        return holds
    if relation.kind == "next_to":
        if relation.distance is not None:
            other = context.centre(reference)[0].cpu().numpy()
            return abs(float(np.linalg.norm((centre - other)[:2])) - relation.distance) <= PLACE_TOLERANCE
        return predicate("next_to", [subject], reference=reference)
    if relation.kind == "aligned_with":
        other = context.centre(reference)[0].cpu().numpy()
        axis = 0 if relation.axis == "row" else 1
        return abs(float(centre[axis] - other[axis])) <= ALIGN_TOLERANCE
    if relation.kind == "facing":
        target = np.zeros(2) if reference == ROBOT else context.centre(reference)[0].cpu().numpy()[:2]
        forward = context.rotation(subject)[0].cpu().numpy()[:2, 0]
        towards = target - centre[:2]
        if np.linalg.norm(forward) < 1e-6 or np.linalg.norm(towards) < 1e-6:
            return False
        cosine = float(forward @ towards / (np.linalg.norm(forward) * np.linalg.norm(towards)))
        return cosine >= math.cos(math.radians(FACING_TOLERANCE_DEG))
    if relation.kind == "on_top_of":
        return predicate("on_top", [subject], reference=reference)
    if relation.kind == "inside":
        return predicate("in_container", [subject], container=reference)
    if relation.kind == "stacked":
        info = PREDICATES["stacked"]
        params = {**info.params, "order": "bottom_to_top"}
        return bool(info.function(context, list(relation.objects), **params).all())
    raise ValueError(f"no check for relation kind {relation.kind!r}")
