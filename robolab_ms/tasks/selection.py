"""Choosing tasks: all of them, or those with an attribute or competency axis (`--tag`), a difficulty or a scene.

Filters of different kinds must all hold; several values of one kind mean any of them (`--tag spatial counting`
selects tasks that are spatial or counting). Like RoboLab's `--tag`, a tag is an attribute (color, semantics,
size, conjunction, counting, spatial, affordance, reorientation, stacking, sorting, vague) or an axis (visual,
relational, procedural).
"""

from __future__ import annotations

from collections.abc import Sequence

from robolab_ms.errors import RoboLabError, UnknownNameError
from robolab_ms.tasks.spec import AXIS_OF_ATTRIBUTE, DIFFICULTIES, TaskSpec

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
    parts = [
        f"{kind} {' or '.join(values)}"
        for kind, values in (("tag", tags), ("difficulty", difficulties), ("scene", scenes))
        if values
    ]
    return ", ".join(parts) or "no filter"


def require_some(chosen: Sequence[TaskSpec], how: str) -> None:
    """Raise a clear error when a selection came out empty."""
    if not chosen:
        raise RoboLabError(
            f"no task matches {how}; see `robolab list` for every task's attributes, axes, difficulty and scene"
        )


def select_tasks(
    given: Sequence[str] | None,
    tags: Sequence[str] | None = None,
    difficulties: Sequence[str] | None = None,
    scenes: Sequence[str] | None = None,
) -> list[str]:
    """The tasks to run, as `robolab eval` chooses them: `given` (names or task files; `all` = every known task,
    as is an empty `given` when a filter is set) narrowed by the filters. With filters, unknown names and bad
    files raise with suggestions (without, the caller loads the tasks), and an empty selection raises."""
    from robolab_ms.tasks.spec import load_task, task_names

    given = list(given or [])
    filters = {"tags": tags, "difficulties": difficulties, "scenes": scenes}
    if not any(filters.values()) and ALL_TASKS not in given:
        return given
    names = [task for task in given if task != ALL_TASKS]
    if not given or ALL_TASKS in given:
        names = task_names() + [task for task in names if task not in task_names()]
    if not any(filters.values()):
        return names
    specs = {task: load_task(task) for task in names}  # unknown names and bad files fail here, with suggestions
    chosen = {id(spec) for spec in filter_tasks(list(specs.values()), **filters)}
    selected = [task for task, spec in specs.items() if id(spec) in chosen]
    require_some(selected, describe_filters(**filters))
    return selected
