"""The JSON answer of scene generation: catalog objects and placement relations, read and checked.

The model answers with one JSON object:

    {"objects": [{"name": "mug", "asset": "mug_red"}, {"name": "bowl", "asset": "bowl_white"}],
     "relations": [{"relation": "on_table", "object": "bowl", "x": 0.55, "y": 0.0},
                   {"relation": "left_of", "object": "mug", "reference": "bowl", "distance": 0.2}]}

Frame (the one of every scene file and predicate, stated once in FRAME and sent to the model): the robot base is
the origin, x points away from the robot, y to its left, z up, the table top at z = 0; "left of" is +y as seen
from the robot, "in front of" is closer to the robot (-x), "behind" farther (+x).

Reading an answer never raises on content: every problem (an unknown object, a relation naming nothing, a
contradiction) becomes a line of plain feedback for the model, keyed to the place in the answer.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from robolab_ms.catalog import Catalog
from robolab_ms.errors import did_you_mean
from robolab_ms.scene import DIRECTIONS, SAFE_PLACEMENT

FRAME = (
    "Frame: the robot stands at the origin looking along +x. x points away from the robot, y to the robot's "
    "left, z up; the table top is z = 0 and its usable part spans x 0.25..0.85 m, y -0.45..0.45 m. "
    "'left of' means larger y, 'right of' smaller y, 'in front of' closer to the robot (smaller x), 'behind' "
    "farther from it (larger x), all as seen from the robot. A yaw turns an object about z, counter-clockwise "
    "seen from above; an object 'faces' a target when its own +x axis points at it."
)

SUPPORTS = ("on_top_of", "inside", "stacked")
RELATIONS = ("on_table", *DIRECTIONS, "next_to", "aligned_with", "facing", "random_yaw", *SUPPORTS, "anywhere")
ALIGN_AXES = ("row", "column")  # row: same x (side by side seen from the robot); column: same y (one behind the other)
ROBOT = "robot"
MAX_OBJECTS = 12
MAX_DISTANCE = 0.6  # m, centre to centre


@dataclass(frozen=True)
class Relation:
    """One placement relation of the answer. `objects` holds the subject (several for `stacked`, bottom first),
    `reference` the other object (a container for `inside`, an object or 'robot' for `facing`)."""

    kind: str
    objects: tuple[str, ...]
    reference: str | None = None
    x: float | None = None
    y: float | None = None
    yaw_deg: float | None = None
    distance: float | None = None
    axis: str | None = None
    index: int = -1  # its place in the answer's relations list

    @property
    def subject(self) -> str:
        return self.objects[0]

    def describe(self) -> str:
        """The relation in words, for feedback and reports."""
        if self.kind == "on_table":
            return f"'{self.subject}' on the table at x={self.x:g}, y={self.y:g}"
        if self.kind == "stacked":
            return "stack " + " under ".join(f"'{name}'" for name in self.objects)
        if self.kind in ("random_yaw", "anywhere"):
            return f"'{self.subject}' {self.kind.replace('_', ' ')}"
        words = {
            "on_top_of": "on top of",
            "inside": "inside",
            "next_to": "next to",
            "aligned_with": "aligned with",
            "facing": "facing",
        }.get(self.kind, self.kind.replace("_", " "))
        extra = f" at {self.distance:g} m" if self.distance is not None else ""
        extra += f" in a {self.axis}" if self.axis else ""
        return f"'{self.subject}' {words} '{self.reference}'{extra}"

    def where(self) -> str:
        return f"relations[{self.index}]"


@dataclass
class SceneProposal:
    """An answer, read: objects (scene name -> catalog name, in order), relations, and the problems found."""

    objects: dict[str, str] = field(default_factory=dict)
    relations: list[Relation] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)

    def support_of(self) -> dict[str, str]:
        """For each object resting on or in another: that support (from on_top_of, inside and stacked)."""
        support: dict[str, str] = {}
        for relation in self.relations:
            if relation.kind in ("on_top_of", "inside"):
                support[relation.subject] = relation.reference
            elif relation.kind == "stacked":
                for below, above in zip(relation.objects, relation.objects[1:]):
                    support[above] = below
        return support

    def base_of(self, name: str) -> str:
        """The object at the bottom of `name`'s pile (the one standing on the table)."""
        support = self.support_of()
        seen = {name}
        while name in support and support[name] not in seen:
            name = support[name]
            seen.add(name)
        return name


def system_prompt(catalog: Catalog, required: list[str] | None = None) -> str:
    """The instructions for the model: the answer format, the frame, the relations and the catalog to choose from."""
    lines = [
        "You lay out tabletop scenes for a robot manipulation benchmark. Answer with ONE JSON object and nothing else:",
        '{"objects": [{"name": "<unique scene name, letters digits underscores>", "asset": "<catalog name>"}, ...],',
        ' "relations": [{"relation": "<kind>", ...}, ...]}',
        FRAME,
        "Relations (distances in metres, centre to centre):",
        '- {"relation": "on_table", "object": A, "x": X, "y": Y, "yaw_deg": optional}: A stands on the table there.',
        '- {"relation": "left_of" | "right_of" | "in_front_of" | "behind", "object": A, "reference": B, '
        '"distance": optional}: A is in that direction from B.',
        '- {"relation": "next_to", "object": A, "reference": B, "distance": optional}: A beside B, any side.',
        '- {"relation": "aligned_with", "object": A, "reference": B, "axis": "row" | "column"}: row = same x (side '
        "by side as the robot sees them), column = same y (one behind the other).",
        '- {"relation": "facing", "object": A, "reference": B or "robot"}: A turned so its +x axis points at B.',
        '- {"relation": "random_yaw", "object": A}: any yaw.',
        '- {"relation": "on_top_of", "object": A, "reference": B}: A rests on B.',
        '- {"relation": "inside", "object": A, "reference": C}: A rests inside container C (containers are marked).',
        '- {"relation": "stacked", "objects": [BOTTOM, ..., TOP]}: a stack, the first on the table.',
        '- {"relation": "anywhere", "object": A}: A somewhere free on the table (the default for unplaced objects).',
        f"Use at most {MAX_OBJECTS} objects. Objects must not overlap; the solver finds free places and a physics "
        "check drops everything: unstable piles are reported back to you.",
    ]
    if required:
        lines.append("The scene must contain these catalog objects: " + ", ".join(required) + ".")
    lines.append("Catalog (name: class, colours; * = container):")
    for name in catalog.names():
        entry = catalog[name]
        if entry.is_fixture:
            continue
        size = "x".join(f"{value * 100:.0f}" for value in entry.dimensions)
        lines.append(
            f"{name}{'*' if entry.is_container else ''}: {entry.object_class}, "
            f"{'/'.join(entry.colors) or '-'}, {size} cm"
        )
    return "\n".join(lines)


_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def read_proposal(answer: dict[str, Any], catalog: Catalog) -> SceneProposal:
    """The answer as a SceneProposal; everything wrong with it is in `problems` (plain sentences for the model)."""
    proposal = SceneProposal()
    problems = proposal.problems
    objects = answer.get("objects")
    if not isinstance(objects, list) or not objects:
        problems.append('"objects" must be a non-empty list of {"name": ..., "asset": ...}')
        return proposal
    known = catalog.names()
    for index, item in enumerate(objects[: MAX_OBJECTS + 1]):
        if isinstance(item, str):
            item = {"asset": item}
        if not isinstance(item, dict) or not isinstance(item.get("asset"), str):
            problems.append(f'objects[{index}] must be {{"name": ..., "asset": "<catalog name>"}}, got {item!r}')
            continue
        asset = item["asset"].strip()
        name = str(item.get("name") or asset).strip().replace(" ", "_").replace("-", "_")
        if asset not in known:
            problems.append(f"objects[{index}]: unknown catalog object '{asset}'. {did_you_mean(asset, known)}")
            continue
        if catalog[asset].is_fixture:
            problems.append(f"objects[{index}]: '{asset}' is a fixture (a shelf or rack); choose a movable object")
            continue
        if not _NAME.match(name) or name in ("table", "robot", "robot_pedestal"):
            problems.append(
                f"objects[{index}]: name '{name}' must start with a letter and use letters, digits and "
                "underscores only, and not be table or robot"
            )
            continue
        if name in proposal.objects:
            problems.append(f"objects[{index}]: name '{name}' is used twice; give each object a unique name")
            continue
        proposal.objects[name] = asset
    if len(objects) > MAX_OBJECTS:
        problems.append(f"too many objects ({len(objects)}); use at most {MAX_OBJECTS}")
    relations = answer.get("relations", [])
    if not isinstance(relations, list):
        problems.append('"relations" must be a list')
        relations = []
    for index, item in enumerate(relations):
        relation = _read_relation(index, item, proposal, catalog)
        if relation is not None:
            proposal.relations.append(relation)
    problems.extend(contradictions(proposal))
    return proposal


def _read_relation(index: int, item: Any, proposal: SceneProposal, catalog: Catalog) -> Relation | None:
    where = f"relations[{index}]"
    problems = proposal.problems
    if not isinstance(item, dict) or not isinstance(item.get("relation"), str):
        problems.append(f'{where} must be an object with a "relation" field, got {item!r}')
        return None
    kind = item["relation"].strip().lower().replace(" ", "_")
    if kind not in RELATIONS:
        problems.append(f"{where}: unknown relation '{kind}'. {did_you_mean(kind, RELATIONS)}")
        return None

    def object_name(key: str, allow_robot: bool = False) -> str | None:
        value = item.get(key)
        if allow_robot and value == ROBOT:
            return ROBOT
        if not isinstance(value, str) or value not in proposal.objects:
            listed = list(proposal.objects)
            problems.append(
                f'{where} ({kind}): "{key}" {value!r} is not one of the objects. {did_you_mean(str(value), listed)}'
            )
            return None
        return value

    def number(key: str, low: float, high: float, required: bool) -> float | None | bool:
        value = item.get(key)
        if value is None and not required:
            return None
        if (
            not isinstance(value, (int, float))
            or isinstance(value, bool)
            or not math.isfinite(value)
            or not low <= value <= high
        ):
            problems.append(f'{where} ({kind}): "{key}" must be a number in [{low:g}, {high:g}], got {value!r}')
            return False
        return float(value)

    if kind == "stacked":
        names = item.get("objects")
        if not isinstance(names, list) or len(names) < 2:
            problems.append(f'{where} (stacked): "objects" must list at least two objects, bottom first')
            return None
        if len(set(names)) != len(names):
            problems.append(f"{where} (stacked): an object appears twice in the stack {names}")
            return None
        for name in names:
            if name not in proposal.objects:
                problems.append(
                    f"{where} (stacked): {name!r} is not one of the objects. "
                    f"{did_you_mean(str(name), list(proposal.objects))}"
                )
                return None
        return Relation(kind, tuple(names), index=index)
    subject = object_name("object")
    if subject is None:
        return None
    if kind in ("random_yaw", "anywhere"):
        return Relation(kind, (subject,), index=index)
    if kind == "on_table":
        x = number("x", *SAFE_PLACEMENT["x"], required=True)
        y = number("y", *SAFE_PLACEMENT["y"], required=True)
        yaw = number("yaw_deg", -360.0, 360.0, required=False)
        if x is False or y is False or yaw is False:
            return None
        return Relation(kind, (subject,), x=x, y=y, yaw_deg=yaw, index=index)
    reference = object_name("reference", allow_robot=kind == "facing")
    if reference is None:
        return None
    if reference == subject:
        problems.append(f"{where} ({kind}): '{subject}' cannot be placed relative to itself")
        return None
    if kind == "inside" and not catalog[proposal.objects[reference]].is_container:
        containers = [name for name, asset in proposal.objects.items() if catalog[asset].is_container]
        problems.append(
            f"{where} (inside): '{reference}' ({proposal.objects[reference]}) is not a container. "
            + (
                f"Containers among your objects: {', '.join(containers)}"
                if containers
                else "Add a container (marked * in the catalog) or use on_top_of"
            )
        )
        return None
    distance = None
    if kind in DIRECTIONS or kind == "next_to":
        distance = number("distance", 0.0, MAX_DISTANCE, required=False)
        if distance is False:
            return None
    axis = None
    if kind == "aligned_with":
        axis = item.get("axis", "row")
        if axis not in ALIGN_AXES:
            problems.append(
                f"{where} (aligned_with): \"axis\" must be 'row' (same x) or 'column' (same y), got {axis!r}"
            )
            return None
    return Relation(kind, (subject,), reference=reference, distance=distance, axis=axis, index=index)


def contradictions(proposal: SceneProposal) -> list[str]:
    """Relations that cannot all hold: two places for one object, supports in a loop, orders in a circle (a left
    of b left of a), directions that two fixed table positions break."""
    problems = []
    placed_by: dict[str, Relation] = {}  # the relation giving each object its support or fixed place
    for relation in proposal.relations:
        subjects = relation.objects[1:] if relation.kind == "stacked" else relation.objects
        if relation.kind == "stacked" or relation.kind in ("on_top_of", "inside", "on_table"):
            for name in subjects:
                earlier = placed_by.get(name)
                if earlier is not None:
                    problems.append(
                        f"{relation.where()} ({relation.describe()}) contradicts {earlier.where()} "
                        f"({earlier.describe()}): '{name}' cannot be in both places; keep one"
                    )
                else:
                    placed_by[name] = relation
        if (
            relation.kind == "stacked"
            and relation.objects[0] in placed_by
            and placed_by[relation.objects[0]].kind in ("on_top_of", "inside")
        ):
            earlier = placed_by[relation.objects[0]]
            problems.append(
                f"{relation.where()} ({relation.describe()}) starts on the table, but {earlier.where()} "
                f"({earlier.describe()}) puts '{relation.objects[0]}' on another object"
            )
    support = proposal.support_of()
    for name in support:
        chain, current = [name], name
        while current in support:
            current = support[current]
            if current in chain:
                problems.append(
                    "the supports form a loop ("
                    + " on ".join(f"'{n}'" for n in chain + [current])
                    + "); let the bottom object stand on the table"
                )
                break
            chain.append(current)
    # strict orders along x and y: an edge a -> b means a's coordinate is larger than b's
    for axis in (0, 1):
        edges: dict[str, set[str]] = {}
        origin: dict[tuple[str, str], Relation] = {}
        for relation in proposal.relations:
            if relation.kind not in DIRECTIONS or DIRECTIONS[relation.kind][axis] == 0.0:
                continue
            a, b = proposal.base_of(relation.subject), proposal.base_of(relation.reference)
            if a == b:
                problems.append(
                    f"{relation.where()} ({relation.describe()}): the two objects are in one pile, so "
                    "they cannot be beside each other; drop one of the relations"
                )
                continue
            larger, smaller = (a, b) if DIRECTIONS[relation.kind][axis] > 0 else (b, a)
            edges.setdefault(larger, set()).add(smaller)
            origin.setdefault((larger, smaller), relation)
        cycle = _find_cycle(edges)
        if cycle:
            involved = sorted({origin[(a, b)].index for a, b in zip(cycle, cycle[1:]) if (a, b) in origin})
            by_index = {relation.index: relation for relation in proposal.relations}
            described = "; ".join(f"relations[{i}] ({by_index[i].describe()})" for i in involved)
            problems.append(
                f"contradictory directions: {described} go round in a circle "
                f"({' > '.join(cycle)} along {'xy'[axis]}); drop or reverse one of them"
            )
    fixed = {relation.subject: relation for relation in proposal.relations if relation.kind == "on_table"}
    for relation in proposal.relations:
        if relation.kind in DIRECTIONS and relation.subject in fixed and relation.reference in fixed:
            a, b = fixed[relation.subject], fixed[relation.reference]
            dx, dy = a.x - b.x, a.y - b.y
            ux, uy = DIRECTIONS[relation.kind]
            planar = math.hypot(dx, dy)
            if planar < 1e-9 or dx * ux + dy * uy < math.cos(math.radians(45.0)) * planar:
                problems.append(
                    f"{relation.where()} ({relation.describe()}) contradicts the fixed places "
                    f"{a.where()} and {b.where()}: at those positions it does not hold; change a "
                    "position or drop the relation"
                )
    return problems


def _find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """A cycle of the directed graph (as a closed list of nodes), or None."""
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for following in sorted(edges.get(node, ())):
            if state.get(following) == 1:
                return path[path.index(following) :] + [following]
            if state.get(following) is None:
                found = visit(following)
                if found:
                    return found
        state[node] = 2
        path.pop()
        return None

    for node in sorted(edges):
        if state.get(node) is None:
            found = visit(node)
            if found:
                return found
    return None
