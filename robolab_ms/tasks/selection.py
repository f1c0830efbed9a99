"""Choosing tasks: all of them, or those with an attribute or competency axis (`--tag`), a difficulty or a scene.

Filters of different kinds must all hold; several values of one kind mean any of them (`--tag spatial counting`
selects tasks that are spatial or counting). Like RoboLab's `--tag`, a tag is an attribute (color, semantics,
size, conjunction, counting, spatial, affordance, reorientation, stacking, sorting, vague) or an axis (visual,
relational, procedural).
"""

from __future__ import annotations

from collections.abc import Sequence

from robolab_ms.errors import RoboLabError, UnknownNameError
from robolab_ms.tasks.spec import AXIS_OF_ATTRIBUTE, TaskSpec

DIFFICULTIES = ("simple", "moderate", "complex")
ALL_TASKS = "all"


def known_tags() -> list[str]:
    """Every value `--tag` accepts: the attributes and the competency axes."""
    return sorted(set(AXIS_OF_ATTRIBUTE) | (set(AXIS_OF_ATTRIBUTE.values()) - {"instruction"}))


def task_tags(spec: TaskSpec) -> set[str]:
    """A task's attributes and its competency axes."""
    return set(spec.attributes) | set(spec.axes)


def filter_tasks(
    specs: Sequence[TaskSpec],
    tags: Sequence[str] | None = None,
    difficulties: Sequence[str] | None = None,
    scenes: Sequence[str] | None = None,
) -> list[TaskSpec]:
    """The specs that carry any of `tags`, have any of `difficulties` and use any of `scenes` (None = no filter).

    Unknown tags and difficulties raise `UnknownNameError`; so does a scene no task of `specs` uses."""
    for tag in tags or ():
        if tag not in known_tags():
            raise UnknownNameError("tag", tag, known_tags())
    for difficulty in difficulties or ():
        if difficulty not in DIFFICULTIES:
            raise UnknownNameError("difficulty", difficulty, DIFFICULTIES)
    used_scenes = {spec.scene.name for spec in specs}
    for scene in scenes or ():
        if scene not in used_scenes:
            raise UnknownNameError("scene (of the chosen tasks)", scene, used_scenes)
    chosen = []
    for spec in specs:
        if tags and not task_tags(spec) & set(tags):
            continue
        if difficulties and spec.difficulty not in difficulties:
            continue
        if scenes and spec.scene.name not in scenes:
            continue
        chosen.append(spec)
    return chosen


def describe_filters(
    tags: Sequence[str] | None = None, difficulties: Sequence[str] | None = None, scenes: Sequence[str] | None = None
) -> str:
    """The filters in words, for messages: "tag spatial, difficulty complex"."""
    parts = [f"{kind} {' or '.join(values)}" for kind, values in
             (("tag", tags), ("difficulty", difficulties), ("scene", scenes)) if values]  # fmt: skip
    return ", ".join(parts) or "no filter"


def require_some(chosen: Sequence[TaskSpec], how: str) -> None:
    """Raise a clear error when a selection came out empty."""
    if not chosen:
        raise RoboLabError(f"no task matches {how}; see `robolab list` for every task's attributes, axes, difficulty "
                           "and scene")  # fmt: skip
