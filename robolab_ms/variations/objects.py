"""Object pose: x, y and yaw offsets of chosen objects from the scene's layout, by collision-aware rejection sampling.

Objects are moved one group at a time in scene order; a group is an object and, for a container, the objects its
outline holds at the layout (they move and turn with it). A candidate pose of a group is kept only when
- every member's outline (the convex hull of its collision points seen from above) lies on the table, 1 cm from
  its edge;
- the group's centre is where scene files may place objects and within the arm's comfortable reach (0.8 m from the
  base, or as far as the layout already puts it: the oracle must still carry objects over a bin's walls there);
- its outline keeps 1 cm from every other object's outline (separating axes, exact for the convex outlines: the
  bounding circles RoboLab uses waste space around long objects).
A group that finds no such pose in 100 tries keeps the scene's own (jittered) pose, which every other group was
checked against, so the episode never starts in collision. Then the task's success conditions are evaluated (their
geometric part: contact flags relaxed, unless the scene's own layout already satisfies that): a drawing that solves
the task is drawn again, up to 10 times, after which the scene's own poses are kept. The recorded fields
`obj_<name>_dx`, `_dy`, `_dyaw` are every chosen object's actual offset from its place in the layout (m, rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from robolab_ms.variations.base import Axis, Context, FieldValue, Names, Param, Range, Uniform, VariationError, stream

RETRIES = 100  # candidate poses per group (RoboLab's number)
SOLVED_ATTEMPTS = 10  # whole drawings tried before the scene's own poses are kept
MARGIN = 0.01  # m: between outlines, and to the table's edge
REACH = 0.8  # m: largest horizontal distance of a group's centre from the robot base (unless its layout is further)


@dataclass
class _Body:
    """One scene object: its layout placement, outline at yaw 0 (about its own origin), and current pose."""

    name: str
    placement: Any
    base_outline: np.ndarray  # (K, 2), counter-clockwise, at x = y = yaw = 0
    x: float
    y: float
    yaw: float
    z: float

    def outline(self, x: float | None = None, y: float | None = None, yaw: float | None = None) -> np.ndarray:
        x, y, yaw = (self.x if x is None else x), (self.y if y is None else y), (self.yaw if yaw is None else yaw)
        c, s = math.cos(yaw), math.sin(yaw)
        return self.base_outline @ np.array([[c, s], [-s, c]]) + np.array([x, y])


class ObjectPoseAxis(Axis):
    name = "objects"
    summary = "x, y and yaw offsets of objects from the scene's layout (collision-aware rejection sampling)"
    params = (
        Param(
            "xy",
            "offset",
            Uniform(0.0, 0.0),
            Uniform(-0.1, 0.1),
            "x and y offset from the layout",
            -0.5,
            0.5,
            unit=" m",
        ),
        Param("yaw", "offset", Uniform(0.0, 0.0), Uniform(-0.5, 0.5), "yaw offset", -math.pi, math.pi, unit=" rad"),
        Param(
            "names",
            "names",
            Names(None),
            Names(None),
            "which objects (default: all); a container's contents move with it",
        ),
    )
    shorthand = "xy"
    presets = {"10cm": {"xy": 0.1}, "20cm": {"xy": 0.2}, "30cm": {"xy": 0.3}}

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        chosen = ranges["names"].names
        known = context.task.scene.object_names()
        for name in chosen or ():
            if name not in known:
                raise VariationError(
                    f"objects.names: '{name}' is not an object of scene {context.task.scene.name} ({', '.join(known)})"
                )
        return {}  # drawn when the episode's state is set: the scene's own jitter must be known first

    def initialize(self, env: Any, env_idx: Any, ranges: dict[str, Range], fields: dict[str, FieldValue]) -> None:
        seed = int(env._episode_seed[0])
        scene, catalog = env.task_spec.scene, env.catalog
        bodies = _bodies(env)
        groups = _groups(scene, catalog)
        chosen_names = ranges["names"].names
        chosen = [g for g in groups if chosen_names is None or any(name in chosen_names for name in g)]
        start = {name: (b.x, b.y, b.yaw) for name, b in bodies.items()}
        streams = {group[0]: stream(seed, self.name, group[0]) for group in chosen}
        table = _table_box(scene)
        check = _geometric_conditions(env)  # false implies the strict conditions are false too
        if not check or _solved(env, check):  # the layout itself meets the geometric part: judge by the strict ones
            check = list(env.task_spec.success)
        placed = False
        for _ in range(SOLVED_ATTEMPTS):
            for name, (x, y, yaw) in start.items():
                bodies[name].x, bodies[name].y, bodies[name].yaw = x, y, yaw
            for group in chosen:
                _place_group(group, bodies, streams[group[0]], ranges, table)
            _apply(env, bodies)
            if not _solved(env, check):
                placed = True
                break
        if not placed:
            for name, (x, y, yaw) in start.items():
                bodies[name].x, bodies[name].y, bodies[name].yaw = x, y, yaw
            _apply(env, bodies)
        for group in chosen:
            for name in group:
                body = bodies[name]
                fields[f"obj_{name}_dx"] = round(body.x - body.placement.xy[0], 5)
                fields[f"obj_{name}_dy"] = round(body.y - body.placement.xy[1], 5)
                fields[f"obj_{name}_dyaw"] = round(_wrap(body.yaw - body.placement.yaw), 5)


def _bodies(env: Any) -> dict[str, _Body]:
    """Every scene object with its current (jittered) pose."""
    from robolab_ms.scene import footprint

    bodies = {}
    for placement in env.task_spec.scene.objects:
        entry = env.catalog[placement.asset]
        outline = footprint(entry, replace(placement, xy=(0.0, 0.0), yaw=0.0))
        pose = env.objects[placement.name].pose
        p, q = pose.p[0].tolist(), pose.q[0].tolist()
        bodies[placement.name] = _Body(placement.name, placement, outline, p[0], p[1], _yaw(q, placement.tilt), p[2])
    return bodies


def _groups(scene: Any, catalog: Any) -> list[tuple[str, ...]]:
    """Objects that move together: each container with the objects its outline holds at the layout (container
    first), an object with the objects resting on it (scene field `rests_on`), every other object alone; in scene
    order. Fixtures (shelves) and what stands on them stay where they are."""
    from robolab_ms.scene import OVERLAP_TOLERANCE, footprint
    from robolab_ms.scene.outlines import outline_inside

    outlines = {p.name: footprint(catalog[p.asset], p) for p in scene.objects}
    still = {
        p.name
        for p in scene.objects
        if p.fixture or any(scene.placement(support).fixture for support in scene.supports(p.name))
    }
    held: dict[str, str] = {
        p.name: scene.base(p.name) for p in scene.objects if p.on is not None and p.name not in still
    }  # piles
    for outer in scene.objects:
        if not catalog[outer.asset].is_container:
            continue
        for inner in scene.objects:
            if (
                inner.name != outer.name
                and inner.name not in held
                and inner.name not in still
                and not catalog[inner.asset].is_container
            ):
                if outline_inside(outlines[inner.name], outlines[outer.name], OVERLAP_TOLERANCE):
                    held[inner.name] = outer.name
    for name in list(held):  # a pile inside a container moves with the container
        while held[name] in held:
            held[name] = held[held[name]]
    groups = []
    for placement in scene.objects:
        if placement.name in held or placement.name in still:
            continue
        groups.append((placement.name, *[name for name, outer in held.items() if outer == placement.name]))
    return groups


def _table_box(scene: Any) -> tuple[np.ndarray, np.ndarray]:
    from robolab_ms.scene import TABLE_CENTER_XY

    half = np.asarray(scene.table_size) / 2
    centre = np.asarray(TABLE_CENTER_XY)
    return centre - half + MARGIN, centre + half - MARGIN


def _place_group(
    group: tuple[str, ...],
    bodies: dict[str, _Body],
    rng: np.random.Generator,
    ranges: dict[str, Range],
    table: tuple[np.ndarray, np.ndarray],
) -> None:
    """Try up to RETRIES poses of `group` around its layout pose; move it to the first one that fits."""
    from robolab_ms.scene import SAFE_PLACEMENT

    leader = bodies[group[0]]
    x0, y0 = leader.placement.xy
    others = [b.outline() for name, b in bodies.items() if name not in group]
    lows = [o.min(axis=0) for o in others]
    highs = [o.max(axis=0) for o in others]
    xy, yaw_range = ranges["xy"], ranges["yaw"]
    reach = max(REACH, math.hypot(x0, y0))
    for _ in range(RETRIES):
        dx, dy, dyaw = xy.draw(rng), xy.draw(rng), yaw_range.draw(rng)
        x, y = x0 + dx, y0 + dy
        (x_low, x_high), (y_low, y_high) = SAFE_PLACEMENT["x"], SAFE_PLACEMENT["y"]
        if not (x_low <= x <= x_high and y_low <= y <= y_high):
            continue
        if math.hypot(x, y) > reach:
            continue
        poses = {name: _moved(bodies[name], (x0, y0), dx, dy, dyaw) for name in group}
        outlines = [bodies[name].outline(*poses[name]) for name in group]
        if any((o.min(axis=0) < table[0]).any() or (o.max(axis=0) > table[1]).any() for o in outlines):
            continue
        if all(_apart(o, other, low, high) for o in outlines for other, low, high in zip(others, lows, highs)):
            for name in group:
                bodies[name].x, bodies[name].y, bodies[name].yaw = poses[name]
            return


def _moved(body: _Body, pivot: tuple[float, float], dx: float, dy: float, dyaw: float) -> tuple[float, float, float]:
    """A group member's layout pose turned by dyaw about the group's layout centre `pivot` and moved by (dx, dy)."""
    px, py = body.placement.xy[0] - pivot[0], body.placement.xy[1] - pivot[1]
    c, s = math.cos(dyaw), math.sin(dyaw)
    return pivot[0] + c * px - s * py + dx, pivot[1] + s * px + c * py + dy, body.placement.yaw + dyaw


def _apart(a: np.ndarray, b: np.ndarray, b_low: np.ndarray, b_high: np.ndarray) -> bool:
    """Whether convex outlines a and b are at least MARGIN apart along some separating axis."""
    from robolab_ms.scene.outlines import outlines_overlap

    a_low, a_high = a.min(axis=0), a.max(axis=0)
    if (a_low - b_high >= MARGIN).any() or (b_low - a_high >= MARGIN).any():
        return True
    return outlines_overlap(a, b) <= -MARGIN


def _apply(env: Any, bodies: dict[str, _Body]) -> None:
    """Put every object at its body's pose (height kept), at rest."""
    import torch
    from mani_skill.utils.structs.pose import Pose

    from robolab_ms.catalog.procedural import quat_multiply, yaw_quat

    for name, body in bodies.items():
        actor = env.objects[name]
        q = quat_multiply(yaw_quat(body.yaw), body.placement.tilt)
        actor.set_pose(
            Pose.create_from_pq(
                torch.tensor([[body.x, body.y, body.z]], dtype=torch.float32), torch.tensor([q], dtype=torch.float32)
            )
        )
        actor.set_linear_velocity(torch.zeros((1, 3)))
        actor.set_angular_velocity(torch.zeros((1, 3)))


def _geometric_conditions(env: Any) -> list:
    """The success conditions with their contact flags relaxed (None when no condition has a flag)."""
    conditions = env.task_spec.success
    if not any(c.require_contact_with or c.require_gripper_detached or c.require_picked_up for c in conditions):
        return []
    return [
        replace(c, require_contact_with=False, require_gripper_detached=False, require_picked_up=False)
        for c in conditions
    ]


def _solved(env: Any, conditions: Any) -> bool:
    from robolab_ms.tasks.predicates import evaluate_condition

    context = env.eval_context
    context.refresh()
    solved = any(bool(evaluate_condition(context, condition)[0]) for condition in conditions)
    context.refresh()
    return solved


def _yaw(q: list[float], tilt: tuple[float, ...]) -> float:
    """The yaw about world z of an object whose orientation is yaw_quat(yaw) * tilt."""
    from robolab_ms.catalog.procedural import quat_multiply

    w, x, y, z = tilt
    turn = quat_multiply(q, [w, -x, -y, -z])  # q * tilt^-1
    return 2.0 * math.atan2(turn[3], turn[0])


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi
