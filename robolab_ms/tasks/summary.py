"""Benchmark totals: our tasks' counts next to RoboLab-120's (`robolab list --summary`).

RoboLab's side comes from robolab120.yaml next to this module (facts carried over from RoboLab's task table and
scene layouts); ours from the task specs. Both sides are reduced to the same `TaskFacts`, so every total is computed
by one function for both. Totals: tasks, scenes, tasks per attribute, per competency axis and per difficulty label,
the episode-length histogram, and objects per task. "Objects per task" counts the objects of the task's scene that a
policy sees: targets, distractors, containers and fixtures, not the table or the robot's stand (our scene files list
exactly those; RoboLab's count leaves out its table, robot stand and bodies parked below the floor).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from robolab_ms.content import Fields, load_yaml
from robolab_ms.errors import RoboLabError
from robolab_ms.tasks.spec import AXIS_OF_ATTRIBUTE, DIFFICULTIES, TaskSpec, task_file

REFERENCE_FILE = Path(__file__).with_name("robolab120.yaml")
ATTRIBUTE_ORDER = (
    "semantics",
    "color",
    "size",
    "spatial",
    "conjunction",
    "counting",
    "affordance",
    "sorting",
    "stacking",
    "reorientation",
    "vague",
)
AXIS_ORDER = ("visual", "relational", "procedural")
NO_ATTRIBUTE = "(no attribute)"
FORMATS = ("text", "csv", "markdown")
SECTION_TITLES = {
    "benchmark": "benchmark",
    "attribute": "tasks per attribute",
    "axis": "tasks per competency axis",
    "difficulty": "tasks per difficulty",
    "episode_seconds": "tasks per episode length (s)",
    "objects_per_task": "objects per task",
}


@dataclass(frozen=True)
class TaskFacts:
    """What the totals count of one task: its scene, length, attributes, subtasks, difficulty and object count."""

    name: str
    scene: str
    episode_seconds: float
    attributes: tuple[str, ...]
    subtasks: int
    difficulty_score: int
    difficulty: str
    objects: int

    @property
    def axes(self) -> tuple[str, ...]:
        return tuple(sorted({AXIS_OF_ATTRIBUTE[a] for a in self.attributes} - {"instruction"}))


@dataclass(frozen=True)
class TotalRow:
    """One total on both sides: `section` (attribute, difficulty, ...), `item` (spatial, simple, ...)."""

    section: str
    item: str
    ours: float | None  # None: not defined for this side (objects per task of no task)
    robolab: float | None

    @property
    def difference(self) -> float | None:
        return None if self.ours is None or self.robolab is None else self.ours - self.robolab


@dataclass(frozen=True)
class Summary:
    """Our totals next to RoboLab's, the RoboLab tasks we lack, our tasks RoboLab lacks, and per-task differences."""

    rows: tuple[TotalRow, ...]
    missing: tuple[str, ...]  # RoboLab's tasks (of the selection) not among ours
    extra: tuple[str, ...]  # our tasks (of the selection) that are not RoboLab's
    robolab_total: int  # RoboLab's tasks in the selection (120 without filters)
    task_differences: tuple[tuple[str, str, str, str], ...]  # (task, field, ours, RoboLab's)


def facts_of_spec(spec: TaskSpec) -> TaskFacts:
    """The facts of one of our task specs."""
    return TaskFacts(
        spec.name,
        spec.scene.name,
        spec.episode_seconds,
        spec.attributes,
        spec.num_subtasks,
        spec.difficulty_score,
        spec.difficulty,
        len(spec.scene.objects),
    )


def robolab_facts(file: Path = REFERENCE_FILE) -> list[TaskFacts]:
    """RoboLab-120's tasks as listed in `file` (default: the shipped robolab120.yaml), checked."""
    fields = Fields(load_yaml(file), file)
    fields.only(["tasks", "scene_objects"])
    scene_objects = fields.sub("scene_objects")
    tasks = fields.sub("tasks")
    facts = []
    for name in tasks.data:
        task = tasks.sub(name)
        task.only(["scene", "seconds", "attributes", "subtasks", "difficulty_score", "difficulty"])
        scene = task.name_in("scene", scene_objects.data, "scene (of scene_objects)")
        facts.append(
            TaskFacts(
                name=name,
                scene=scene,
                episode_seconds=task.positive("seconds", 3600.0, unit="s"),
                attributes=tuple(task.names_in("attributes", AXIS_OF_ATTRIBUTE, "attribute")),
                subtasks=task.get("subtasks", int),
                difficulty_score=task.get("difficulty_score", int),
                difficulty=task.choice("difficulty", DIFFICULTIES),
                objects=scene_objects.get(scene, int),
            )
        )
    return facts


def totals(facts: Sequence[TaskFacts]) -> dict[tuple[str, str], float]:
    """Every total of a set of tasks, keyed by (section, item). Counts of 0 are left out; objects per task is
    mean, min and max (absent for no tasks)."""
    counts: dict[tuple[str, str], float] = {
        ("benchmark", "tasks"): len(facts),
        ("benchmark", "scenes"): len({task.scene for task in facts}),
    }

    def add(section: str, item: str) -> None:
        counts[(section, item)] = counts.get((section, item), 0) + 1

    for task in facts:
        for attribute in task.attributes or (NO_ATTRIBUTE,):
            add("attribute", attribute)
        for axis in task.axes:
            add("axis", axis)
        add("difficulty", task.difficulty)
        add("episode_seconds", f"{task.episode_seconds:g}")
    if facts:
        objects = [task.objects for task in facts]
        counts[("objects_per_task", "mean")] = sum(objects) / len(objects)
        counts[("objects_per_task", "min")] = min(objects)
        counts[("objects_per_task", "max")] = max(objects)
    return counts


def _row_order(key: tuple[str, str]) -> tuple:
    section, item = key
    orders = {
        "benchmark": ("tasks", "scenes"),
        "attribute": ATTRIBUTE_ORDER + (NO_ATTRIBUTE,),
        "axis": AXIS_ORDER,
        "difficulty": DIFFICULTIES,
        "objects_per_task": ("mean", "min", "max"),
    }
    rank = orders[section].index(item) if section in orders else float(item)
    return (list(SECTION_TITLES).index(section), rank)


def task_differences(ours: Sequence[TaskFacts], theirs: Sequence[TaskFacts]) -> list[tuple[str, str, str, str]]:
    """For each task in both: (task, field, our value, RoboLab's value) where scene, episode length, attributes,
    subtasks, difficulty or object count differ."""
    reference = {task.name: task for task in theirs}
    found = []
    for task in ours:
        other = reference.get(task.name)
        if other is None:
            continue
        pairs = {
            "scene": (task.scene, other.scene),
            "episode_seconds": (f"{task.episode_seconds:g}", f"{other.episode_seconds:g}"),
            "attributes": (",".join(sorted(task.attributes)), ",".join(sorted(other.attributes))),
            "subtasks": (str(task.subtasks), str(other.subtasks)),
            "difficulty": (
                f"{task.difficulty} ({task.difficulty_score})",
                f"{other.difficulty} ({other.difficulty_score})",
            ),
            "objects": (str(task.objects), str(other.objects)),
        }
        found += [(task.name, key, mine, theirs_) for key, (mine, theirs_) in pairs.items() if mine != theirs_]
    return found


def select_facts(
    facts: Sequence[TaskFacts],
    names: Sequence[str] | None = None,
    tags: Sequence[str] | None = None,
    difficulties: Sequence[str] | None = None,
    scenes: Sequence[str] | None = None,
) -> list[TaskFacts]:
    """The tasks among `names` (None: all) that carry any of `tags` (attribute or axis), have any of `difficulties`
    and use any of `scenes`, by the tasks' own facts (None = no filter): `robolab list`'s filters, applied to
    RoboLab's side."""
    chosen = []
    for task in facts:
        if names is not None and task.name not in names:
            continue
        if tags and not (set(task.attributes) | set(task.axes)) & set(tags):
            continue
        if difficulties and task.difficulty not in difficulties:
            continue
        if scenes and task.scene not in scenes:
            continue
        chosen.append(task)
    return chosen


def summarize(ours: Sequence[TaskFacts], theirs: Sequence[TaskFacts]) -> Summary:
    """Our totals next to RoboLab's (both over the tasks given), with what is missing and what differs."""
    mine, reference = totals(ours), totals(theirs)
    rows = []
    for key in sorted(set(mine) | set(reference), key=_row_order):
        absent = None if key[0] == "objects_per_task" else 0  # a count of no task is 0; its mean is not defined
        rows.append(TotalRow(*key, mine.get(key, absent), reference.get(key, absent)))
    our_names = {task.name for task in ours}
    their_names = {task.name for task in theirs}
    return Summary(
        tuple(rows),
        tuple(sorted(their_names - our_names)),
        tuple(sorted(our_names - their_names)),
        len(theirs),
        tuple(task_differences(ours, theirs)),
    )


def _number(value: float | None, item: str) -> str:
    """A count as a whole number, a mean with two decimals, "-" for a value not defined."""
    if value is None:
        return "-"
    return f"{value:.2f}" if item == "mean" else f"{value:g}"


def _difference(row: TotalRow) -> str:
    """Ours minus RoboLab's, with its sign ("0" when equal)."""
    text = _number(row.difference, row.item)
    return "+" + text if row.difference is not None and row.difference > 0 else text


def _notes(summary: Summary) -> list[tuple[int, str]]:
    """The missing, extra and differing tasks, in sentences, each with its indent level (0, or 1 under another)."""
    notes = []
    if summary.missing:
        notes.append(
            (
                0,
                f"missing: {len(summary.missing)} of RoboLab's {summary.robolab_total} task(s) are not "
                f"among ours: {', '.join(summary.missing)}",
            )
        )
    elif summary.robolab_total:
        notes.append((0, f"missing: none; all {summary.robolab_total} of RoboLab's task(s) are among ours"))
    else:
        notes.append((0, "RoboLab has no task in this selection"))
    if summary.extra:
        notes.append(
            (0, f"not RoboLab's: {len(summary.extra)} of our task(s), counted on our side: {', '.join(summary.extra)}")
        )
    if summary.task_differences:
        notes.append((0, f"tasks that differ from RoboLab's ({len(summary.task_differences)} difference(s)):"))
        notes += [
            (1, f"{task}: {key} ours {mine}, RoboLab's {theirs}")
            for task, key, mine, theirs in summary.task_differences
        ]
    elif summary.robolab_total > len(summary.missing):
        notes.append(
            (
                0,
                "every task in both has RoboLab's scene, episode length, attributes, subtasks, difficulty "
                "and object count",
            )
        )
    return notes


def format_text(summary: Summary) -> str:
    """An aligned table per section, then the missing and differing tasks."""
    table = [("", "ours", "RoboLab", "difference")]
    for index, row in enumerate(summary.rows):
        if index == 0 or summary.rows[index - 1].section != row.section:
            table.append((SECTION_TITLES[row.section], "", "", ""))
        table.append(("  " + row.item, _number(row.ours, row.item), _number(row.robolab, row.item), _difference(row)))
    widths = [max(len(line[i]) for line in table) for i in range(4)]
    lines = []
    for line in table:
        numbers = "  ".join(cell.rjust(width) for cell, width in zip(line[1:], widths[1:]))
        lines.append(f"{line[0].ljust(widths[0])}  {numbers}".rstrip())
    lines.append("")
    lines += ["  " * level + note for level, note in _notes(summary)]
    return "\n".join(lines) + "\n"


def format_markdown(summary: Summary) -> str:
    """A Markdown table per section, then the missing and differing tasks as a list."""
    lines: list[str] = []
    for index, row in enumerate(summary.rows):
        if index == 0 or summary.rows[index - 1].section != row.section:
            lines += [
                "",
                f"### {SECTION_TITLES[row.section]}",
                "",
                "| | ours | RoboLab | difference |",
                "|---|---:|---:|---:|",
            ]
        lines.append(
            f"| {row.item} | {_number(row.ours, row.item)} | {_number(row.robolab, row.item)} | {_difference(row)} |"
        )
    lines += ["", "### tasks", ""]
    lines += ["  " * level + "- " + note for level, note in _notes(summary)]
    return "\n".join(lines).lstrip("\n") + "\n"


def format_csv(summary: Summary) -> str:
    """One row per total (section, item, ours, robolab, difference), then one per missing task (ours 0, robolab 1)
    and one per differing field of a task (section `task_difference`, item `Task.field`, no difference)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["section", "item", "ours", "robolab", "difference"])
    for row in summary.rows:
        values = [row.ours, row.robolab, row.difference]
        writer.writerow(
            [row.section, row.item] + ["" if value is None else _number(value, row.item) for value in values]
        )
    for task in summary.missing:
        writer.writerow(["missing_task", task, 0, 1, -1])
    for task in summary.extra:
        writer.writerow(["extra_task", task, 1, 0, 1])
    for task, key, mine, theirs in summary.task_differences:
        writer.writerow(["task_difference", f"{task}.{key}", mine, theirs, ""])
    return out.getvalue()


def render(summary: Summary, fmt: str = "text") -> str:
    """The summary as text, csv or markdown."""
    if fmt not in FORMATS:
        raise RoboLabError(f"unknown summary format '{fmt}'; use one of {', '.join(FORMATS)}")
    return {"text": format_text, "csv": format_csv, "markdown": format_markdown}[fmt](summary)


def listing_summary(
    specs: Sequence[TaskSpec],
    named: Sequence[str] | None = None,
    tags: Sequence[str] | None = None,
    difficulties: Sequence[str] | None = None,
    scenes: Sequence[str] | None = None,
) -> Summary:
    """`robolab list --summary`: the chosen specs next to RoboLab's tasks chosen the same way: among the tasks
    `named` with --task (names or files; None: all), by RoboLab's own attributes, difficulty and scene."""
    names = None if named is None else [task_file(task).stem for task in named]
    theirs = select_facts(robolab_facts(), names, tags, difficulties, scenes)
    return summarize([facts_of_spec(spec) for spec in specs], theirs)
