"""From a scene proposal to object poses: a physical solver for piles (on top of, inside, stacked) and a spatial
solver for what stands on the table.

Physical solver: each object resting on or in another is centred on its support's top (on top of, stacked) or
shares the container's interior with the container's other contents, slot by slot along the interior's longer
side, using the catalog's real outlines and interiors; an object that does not fit is a problem. Its height is
not chosen here: the scene loader lowers it onto its support's collision pieces (`rests_on`).

Spatial solver: every pile base (an object standing on the table, with its pile's outline) gets a place inside the
reachable area. Relations are targets: a direction puts the subject that far along +-x / +-y from its reference
(within a narrow cone, so the predicates' 45-degree cone holds), `next_to` puts it beside, `aligned_with` shares
an x or a y, `on_table` fixes a place. Iterations alternate pulling subjects to their targets, pushing overlapping
outlines apart (separating axes, with a gap for the fingers; between an open container and a stack, at least the
height of the stack's upper objects, see `pair_gap`) and keeping outlines in the area. When they do not
converge, the solver relaxes: it drops the relation furthest from holding (a fixed place becomes free), records
it, and continues; relaxed relations are reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import ConvexHull

from robolab_ms.catalog import Catalog
from robolab_ms.generation.proposal import ROBOT, Relation, SceneProposal
from robolab_ms.scene import DIRECTIONS, SAFE_PLACEMENT
from robolab_ms.scene.outlines import outline_points

REACH = {"x": (0.20, 0.85), "y": (-0.45, 0.45)}  # m: where outlines must lie (the robot reaches all of it)
GAP = 0.03  # m: free space the solver aims for between outlines on the table (room for the fingers)
MIN_GAP = 0.01  # m: the least free space it accepts
ITERATIONS = 250
CONE_SHARE = 0.15  # the sideways offset of a direction target is at most this share of its distance
TOLERANCE = 0.004  # m
SLOT_TOLERANCE = 0.005  # m an object may exceed its slot in a container
DEFAULT_GAP_NEXT_TO = 0.03  # m between outlines for next_to without a distance


@dataclass
class Pose:
    """Where an object goes: origin x, y on the table or over its support, yaw (rad), and the support."""

    name: str
    asset: str
    xy: tuple[float, float]
    yaw: float
    rests_on: str | None = None


@dataclass
class Layout:
    """The solver's result: a pose for each object, the relations it had to relax (with why), and problems that
    stop the scene (an object that does not fit where asked)."""

    poses: list[Pose] = field(default_factory=list)
    relaxed: list[tuple[Relation, str]] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    iterations: int = 0


def rotation2(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


def hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull corners of 2-D points."""
    return points[ConvexHull(points).vertices]


# ------------------------------------------------------------------------------------------------ physical solver
@dataclass
class Member:
    """An object of a pile, relative to its support: origin offset and yaw in the support's frame."""

    name: str
    support: str
    offset: np.ndarray
    yaw: float


def solve_piles(proposal: SceneProposal, catalog: Catalog, yaws: dict[str, float], layout: Layout) -> dict[str, Member]:
    """Each supported object's place on its support (relative), from real outlines; misfits go to `layout`."""
    support = proposal.support_of()
    kind_of: dict[str, str] = {}
    for relation in proposal.relations:
        if relation.kind in ("on_top_of", "inside"):
            kind_of[relation.subject] = relation.kind
    children: dict[str, list[str]] = {}
    for name in proposal.objects:  # answer order
        if name in support:
            children.setdefault(support[name], []).append(name)
    members: dict[str, Member] = {}
    for parent, names in children.items():
        entry = catalog[proposal.objects[parent]]
        low, high = entry.bounds[0], entry.bounds[1]
        centre = (low[:2] + high[:2]) / 2
        inside = all(kind_of.get(name) == "inside" for name in names) and entry.is_container
        area = np.array(entry.interior[:2]) if inside and entry.interior else (high[:2] - low[:2])
        along = 0 if area[0] >= area[1] else 1
        slot = area.copy()
        slot[along] = area[along] / len(names)
        for index, name in enumerate(names):
            child = catalog[proposal.objects[name]]
            relative_yaw = yaws.get(name, 0.0)
            points = outline_points(child)[:, :2]
            child_centre = (child.bounds[0][:2] + child.bounds[1][:2]) / 2
            turned = (points - child_centre) @ rotation2(relative_yaw).T
            size = turned.max(axis=0) - turned.min(axis=0)
            if len(names) > 1 or inside:
                for turn in (math.pi / 2, math.pi / 4, -math.pi / 4):  # a quarter or an eighth turn may make it fit
                    if (size <= slot + SLOT_TOLERANCE).all():
                        break
                    turned_more = (points - child_centre) @ rotation2(relative_yaw + turn).T
                    size_more = turned_more.max(axis=0) - turned_more.min(axis=0)
                    if (size_more <= slot + SLOT_TOLERANCE).all():
                        relative_yaw, size = relative_yaw + turn, size_more
                if (size > slot + SLOT_TOLERANCE).any():
                    shared = f", shared with {len(names) - 1} other object(s)" if len(names) > 1 else ""
                    where = "inside" if inside else "on top of"
                    space = "interior" if inside else "top"
                    layout.problems.append(
                        f"'{name}' ({size[0] * 100:.0f} x {size[1] * 100:.0f} cm) does not fit {where} '{parent}' "
                        f"(its {space} is {area[0] * 100:.0f} x {area[1] * 100:.0f} cm{shared}); choose a smaller "
                        f"object, a larger {'container' if inside else 'support'}, or put it on the table"
                    )
            slot_centre = centre.copy()
            slot_centre[along] += -area[along] / 2 + slot[along] * (index + 0.5)
            offset = slot_centre - rotation2(relative_yaw) @ child_centre
            members[name] = Member(name, parent, offset, relative_yaw)
    return members


def pile_outline(base: str, proposal: SceneProposal, catalog: Catalog, members: dict[str, Member]) -> np.ndarray:
    """The outline (convex, base frame) of a base object with everything resting on it."""
    points = [outline_points(catalog[proposal.objects[base]])[:, :2]]

    def add(parent: str, offset: np.ndarray, yaw: float) -> None:
        for member in members.values():
            if member.support != parent:
                continue
            child_offset = offset + rotation2(yaw) @ member.offset
            child_yaw = yaw + member.yaw
            child_points = outline_points(catalog[proposal.objects[member.name]])[:, :2]
            points.append(child_points @ rotation2(child_yaw).T + child_offset)
            add(member.name, child_offset, child_yaw)

    add(base, np.zeros(2), 0.0)
    return hull(np.concatenate(points))


# ------------------------------------------------------------------------------------------------ spatial solver
@dataclass
class Body:
    """A pile base on the table: its pile's outline (base frame), place, yaw, whether its place is fixed, whether
    the base is an open container, and the height from which the highest object resting on top of it could fall."""

    name: str
    outline: np.ndarray
    xy: np.ndarray
    yaw: float
    fixed: bool = False
    facing: str | None = None  # an object's name or 'robot': the yaw follows it
    container: bool = False
    perch: float = 0.0  # m above the table top: the bottom of the pile's highest object resting on top of another
    beside: set[str] = field(default_factory=set)  # the piles a next_to relation ties it to

    def polygon(self) -> np.ndarray:
        return self.outline @ rotation2(self.yaw).T + self.xy

    def extent(self, direction: np.ndarray) -> float:
        """How far the outline reaches from the origin along `direction`."""
        return float(((self.polygon() - self.xy) @ direction).max())


def pair_gap(a: Body, b: Body) -> float:
    """The free space the solver aims for between two piles: GAP, or, between an open container and a pile with
    objects resting on top of others, at least the height those objects sit at, so that one knocked off its
    perch lands on the table and not in the container (unless a next_to relation ties the two)."""
    if a.container != b.container and b.name not in a.beside:
        return max(GAP, b.perch if a.container else a.perch)
    return GAP


def perch_height(base: str, proposal: SceneProposal, catalog: Catalog) -> float:
    """How high above the table top the highest object resting on top of another (not inside a container) in
    `base`'s pile sits (0 when none does)."""
    support = proposal.support_of()
    inside = {relation.subject for relation in proposal.relations if relation.kind == "inside"}

    def bottom(name: str) -> float:
        if name not in support:
            return 0.0
        below = support[name]
        return bottom(below) + float(catalog[proposal.objects[below]].dimensions[2])

    perched = [name for name in support if name not in inside and proposal.base_of(name) == base]
    return max((bottom(name) for name in perched), default=0.0)


def separation(a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray]:
    """Penetration depth of two convex polygons (negative: the gap between them) and the unit axis, from a to b,
    along which moving b by the depth separates them."""
    best, axis = math.inf, np.array([1.0, 0.0])
    for polygon in (a, b):
        edges = np.roll(polygon, -1, axis=0) - polygon
        normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
        lengths = np.linalg.norm(normals, axis=1)
        normals = normals[lengths > 1e-12] / lengths[lengths > 1e-12, None]
        pa, pb = a @ normals.T, b @ normals.T
        overlap = np.minimum(pa.max(0), pb.max(0)) - np.maximum(pa.min(0), pb.min(0))
        index = int(overlap.argmin())
        if overlap[index] < best:
            best, axis = float(overlap[index]), normals[index]
    if (b.mean(axis=0) - a.mean(axis=0)) @ axis < 0:
        axis = -axis
    return best, axis


@dataclass
class Constraint:
    """A relation between two pile bases (or a base and nothing, for aligned rows), as a target for the subject."""

    relation: Relation
    subject: str
    reference: str

    def target(self, bodies: dict[str, Body]) -> np.ndarray:
        """Where the subject should be, given the reference's current place."""
        s, r = bodies[self.subject], bodies[self.reference]
        kind = self.relation.kind
        if kind == "aligned_with":
            target = s.xy.copy()
            target[0 if self.relation.axis == "row" else 1] = r.xy[0 if self.relation.axis == "row" else 1]
            return target
        if kind in DIRECTIONS:
            u = np.array(DIRECTIONS[kind])
            v = np.array([-u[1], u[0]])
            distance = max(self.relation.distance or 0.0, self.least_distance(bodies, u))
            sideways = float((s.xy - r.xy) @ v)
            sideways = min(max(sideways, -CONE_SHARE * distance), CONE_SHARE * distance)
            return r.xy + distance * u + sideways * v
        # next_to: beside, on the side it is already on
        offset = s.xy - r.xy
        norm = float(np.linalg.norm(offset))
        u = offset / norm if norm > 1e-9 else np.array([0.0, 1.0])
        distance = self.relation.distance or (self.least_distance(bodies, u) + DEFAULT_GAP_NEXT_TO - GAP)
        return r.xy + max(distance, self.least_distance(bodies, u)) * u

    def least_distance(self, bodies: dict[str, Body], u: np.ndarray) -> float:
        """The smallest centre distance along u at which subject and reference outlines keep the gap."""
        s, r = bodies[self.subject], bodies[self.reference]
        return r.extent(u) + s.extent(-u) + (GAP if self.relation.kind == "next_to" else pair_gap(s, r))

    def error(self, bodies: dict[str, Body]) -> float:
        """How far the subject is from holding the relation (m)."""
        s, r = bodies[self.subject], bodies[self.reference]
        kind = self.relation.kind
        if kind == "aligned_with":
            axis = 0 if self.relation.axis == "row" else 1
            return abs(float(s.xy[axis] - r.xy[axis]))
        if kind in DIRECTIONS:
            u = np.array(DIRECTIONS[kind])
            offset = s.xy - r.xy
            along = float(offset @ u)
            sideways = abs(float(offset @ np.array([-u[1], u[0]])))
            error = max(0.0, sideways - along)  # outside the 45-degree cone
            if self.relation.distance is not None:
                wanted = max(self.relation.distance, self.least_distance(bodies, u))
                error = max(error, abs(float(np.linalg.norm(offset)) - wanted) - 0.02)
            return error
        distance = float(np.linalg.norm(s.xy - r.xy))
        if self.relation.distance is not None:
            return max(0.0, abs(distance - self.relation.distance) - 0.02)
        gap = -separation(s.polygon(), r.polygon())[0]
        return max(0.0, gap - 0.05)  # the next_to predicate's 5 cm between outlines


def solve_layout(proposal: SceneProposal, catalog: Catalog, seed: int = 0) -> Layout:
    """Poses for every object of the proposal (which must have no problems), with relaxed relations and misfits."""
    rng = np.random.default_rng(seed)
    layout = Layout()
    support = proposal.support_of()
    yaws: dict[str, float] = {name: 0.0 for name in proposal.objects}
    facing: dict[str, str] = {}
    fixed: dict[str, Relation] = {}
    for relation in proposal.relations:
        if relation.kind == "random_yaw":
            yaws[relation.subject] = float(rng.uniform(-math.pi, math.pi))
        elif relation.kind == "on_table":
            fixed[relation.subject] = relation
            if relation.yaw_deg is not None:
                yaws[relation.subject] = math.radians(relation.yaw_deg)
        elif relation.kind == "facing":
            facing[relation.subject] = relation.reference
    members = solve_piles(proposal, catalog, yaws, layout)
    bases = [name for name in proposal.objects if name not in support]
    bodies = {
        name: Body(
            name,
            pile_outline(name, proposal, catalog, members),
            np.zeros(2),
            yaws[name],
            facing=facing.get(name),
            container=catalog[proposal.objects[name]].is_container,
            perch=perch_height(name, proposal, catalog),
        )
        for name in bases
    }
    constraints = []
    for relation in proposal.relations:
        if relation.kind in DIRECTIONS or relation.kind in ("next_to", "aligned_with"):
            subject, reference = proposal.base_of(relation.subject), proposal.base_of(relation.reference)
            if subject != reference:
                constraints.append(Constraint(relation, subject, reference))
    for constraint in constraints:
        if constraint.relation.kind == "next_to":
            bodies[constraint.subject].beside.add(constraint.reference)
            bodies[constraint.reference].beside.add(constraint.subject)
    for name, relation in fixed.items():
        if name in bodies:
            bodies[name].xy = np.array([relation.x, relation.y])
            bodies[name].fixed = True
    _initial_places(bodies, constraints, rng)
    for constraint in constraints:  # a distance too short for the two outlines cannot hold
        relation = constraint.relation
        if relation.kind in DIRECTIONS and relation.distance is not None:
            least = constraint.least_distance(bodies, np.array(DIRECTIONS[relation.kind]))
            if relation.distance < least - 0.02:
                layout.relaxed.append(
                    (
                        relation,
                        f"the distance {relation.distance:g} m is too short for the two "
                        f"outlines, which need at least {least:.2f} m centre to centre",
                    )
                )
    active = list(constraints)
    for _ in range(len(constraints) + len(fixed) + 1):
        converged = _iterate(bodies, active, layout)
        if converged:
            break
        victim = _most_violated(bodies, active)
        if victim is not None:
            active.remove(victim)
            layout.relaxed.append(
                (
                    victim.relation,
                    f"it could not hold together with the other relations and free "
                    f"space (missed by {victim.error(bodies) * 100:.1f} cm)",
                )
            )
            continue
        crowded = [body for body in bodies.values() if body.fixed and _overlaps(body, bodies)]
        if not crowded:  # a stalemate: the relations hold but hold objects too close; relax one that ties them
            touching = {body.name for body in bodies.values() if _overlaps(body, bodies)}
            tied = [c for c in active if c.subject in touching or c.reference in touching]
            if not tied:
                break
            victim = max(tied, key=lambda constraint: constraint.relation.index)
            active.remove(victim)
            layout.relaxed.append((victim.relation, "it kept objects closer than 1 cm to each other"))
            continue
        crowded[-1].fixed = False
        layout.relaxed.append(
            (
                fixed[crowded[-1].name],
                "that place overlaps other objects or leaves the reachable area, so the object was moved",
            )
        )
    if any(_overlaps(body, bodies) for body in bodies.values()):
        layout.problems.append(
            "the objects do not fit side by side in the reachable part of the table (x "
            f"{REACH['x'][0]}..{REACH['x'][1]} m, y {REACH['y'][0]}..{REACH['y'][1]} m); use "
            "fewer or smaller objects, or put some inside containers or on others"
        )
    _face(bodies)
    for name in proposal.objects:
        if name in bodies:
            body = bodies[name]
            xy, yaw, on = body.xy, body.yaw, None
        else:
            xy, yaw = _member_pose(name, members, bodies)
            on = members[name].support
            if name in facing:  # turn about its own place; its slot stays
                yaw = _facing_yaw(xy, facing[name], bodies)
        layout.poses.append(
            Pose(name, proposal.objects[name], (round(float(xy[0]), 4), round(float(xy[1]), 4)), float(yaw), on)
        )
    return layout


def _member_pose(name: str, members: dict[str, Member], bodies: dict[str, Body]) -> tuple[np.ndarray, float]:
    member = members[name]
    if member.support in bodies:
        parent_xy, parent_yaw = bodies[member.support].xy, bodies[member.support].yaw
    else:
        parent_xy, parent_yaw = _member_pose(member.support, members, bodies)
    return parent_xy + rotation2(parent_yaw) @ member.offset, parent_yaw + member.yaw


def _facing_yaw(xy: np.ndarray, target: str, bodies: dict[str, Body]) -> float:
    goal = np.zeros(2) if target == ROBOT else bodies[target].xy if target in bodies else None
    if goal is None:
        return 0.0
    offset = goal - xy
    return math.atan2(offset[1], offset[0]) if np.linalg.norm(offset) > 1e-9 else 0.0


def _face(bodies: dict[str, Body]) -> None:
    for body in bodies.values():
        if body.facing is not None:
            body.yaw = _facing_yaw(body.xy, body.facing, bodies)


def _initial_places(bodies: dict[str, Body], constraints: list[Constraint], rng: np.random.Generator) -> None:
    """Fixed bodies where asked; then each subject at its target from a placed reference (and references from
    placed subjects), repeatedly; the rest at the freest of some random places."""
    placed = {name for name, body in bodies.items() if body.fixed}
    if not placed and bodies:
        first = next(iter(bodies))
        bodies[first].xy = np.array([0.55, 0.0])
        placed.add(first)
    changed = True
    while changed:
        changed = False
        for constraint in constraints:
            s, r = constraint.subject, constraint.reference
            if r in placed and s not in placed:
                bodies[s].xy = bodies[r].xy.copy()
                bodies[s].xy = constraint.target(bodies)
                placed.add(s)
                changed = True
            elif s in placed and r not in placed:
                bodies[r].xy = bodies[s].xy.copy()
                bodies[r].xy = bodies[s].xy - (constraint.target(bodies) - bodies[s].xy)
                placed.add(r)
                changed = True
    for name, body in bodies.items():
        if name in placed:
            continue
        best, best_overlap = None, math.inf
        for _ in range(40):
            body.xy = np.array([rng.uniform(*SAFE_PLACEMENT["x"]), rng.uniform(*SAFE_PLACEMENT["y"])])
            _keep_in_reach(body)
            overlap = sum(
                max(0.0, separation(body.polygon(), bodies[other].polygon())[0] + pair_gap(body, bodies[other]))
                for other in placed
            )
            if overlap < best_overlap:
                best, best_overlap = body.xy.copy(), overlap
        body.xy = best
        placed.add(name)
    for body in bodies.values():
        _keep_in_reach(body)


def _keep_in_reach(body: Body) -> None:
    polygon = body.polygon()
    for axis, key in ((0, "x"), (1, "y")):
        low, high = REACH[key]
        lowest, highest = polygon[:, axis].min(), polygon[:, axis].max()
        if highest - lowest > high - low:  # wider than the area: centre it
            body.xy[axis] += (low + high) / 2 - (lowest + highest) / 2
        elif lowest < low:
            body.xy[axis] += low - lowest
        elif highest > high:
            body.xy[axis] -= highest - high
        body.xy[axis] = min(max(body.xy[axis], SAFE_PLACEMENT[key][0]), SAFE_PLACEMENT[key][1])


def _overlaps(body: Body, bodies: dict[str, Body]) -> bool:
    polygon = body.polygon()
    for key, low_high in (("x", 0), ("y", 1)):
        low, high = REACH[key]
        if polygon[:, low_high].min() < low - TOLERANCE or polygon[:, low_high].max() > high + TOLERANCE:
            return True
    return any(separation(polygon, other.polygon())[0] > -MIN_GAP for other in bodies.values() if other is not body)


def _iterate(bodies: dict[str, Body], constraints: list[Constraint], layout: Layout) -> bool:
    """Pull, push apart, keep in reach, until nothing overlaps and every constraint holds (True) or the
    iterations run out (False)."""
    names = list(bodies)
    for _ in range(ITERATIONS):
        layout.iterations += 1
        _face(bodies)
        for constraint in constraints:
            s, r = bodies[constraint.subject], bodies[constraint.reference]
            move = constraint.target(bodies) - s.xy
            if not s.fixed:
                s.xy = s.xy + 0.5 * move
            elif not r.fixed:
                r.xy = r.xy - 0.5 * move
        for i, first in enumerate(names):
            for second in names[i + 1 :]:
                a, b = bodies[first], bodies[second]
                depth, axis = separation(a.polygon(), b.polygon())
                need = depth + pair_gap(a, b)
                if need <= 0:
                    continue
                share_a = 0.0 if a.fixed else (1.0 if b.fixed else 0.5)
                share_b = 0.0 if b.fixed else (1.0 if a.fixed else 0.5)
                a.xy = a.xy - axis * need * share_a * 1.05
                b.xy = b.xy + axis * need * share_b * 1.05
        for body in bodies.values():
            if not body.fixed:
                _keep_in_reach(body)
        if all(constraint.error(bodies) <= TOLERANCE for constraint in constraints) and not any(
            _overlaps(body, bodies) for body in bodies.values()
        ):
            return True
    return False


def _most_violated(bodies: dict[str, Body], constraints: list[Constraint]) -> Constraint | None:
    """The constraint furthest from holding (the later one on ties), or None when all hold."""
    errors = [(constraint.error(bodies), constraint.relation.index, constraint) for constraint in constraints]
    errors = [item for item in errors if item[0] > TOLERANCE]
    if not errors:
        return None
    return max(errors, key=lambda item: (round(item[0], 3), item[1]))[2]
