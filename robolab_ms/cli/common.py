"""Options and helpers that several `robolab` commands share: the --content option, choosing tasks (--task, --tag,
--difficulty, --scene), the --vary settings and printing an aligned table."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from robolab_ms.errors import RoboLabError

TASK_HELP = (
    "task name(s) as in `robolab list`, e.g. BananaInBowl, or task file(s), e.g. my_tasks/T.yaml (its "
    "scene is found next to it, in a sibling scene_builders/ folder, or by name)"
)


def content_parent() -> argparse.ArgumentParser:
    """A parent parser with --content DIR, for the commands that read tasks and scenes."""
    from robolab_ms.content import CONTENT_ENV

    content = argparse.ArgumentParser(add_help=False)
    content.add_argument(
        "--content",
        action="append",
        default=[],
        metavar="DIR",
        help=f"a folder of your own tasks and scenes (DIR/task_specs/, DIR/scene_builders/), added "
        f"after those of ${CONTENT_ENV}; may be given more than once",
    )
    return content


def task_arguments(tasks: list[str]) -> tuple[str, ...]:
    """The `--task` values, each checked: a known task's name, or a task file's path. A task file is registered as
    `RoboLab-<name>-v1` for this run (replacing a known task of the same name, with a note)."""
    from robolab_ms.tasks.spec import is_task_file, load_task, task_names

    resolved, names = [], {}
    for task in tasks:
        spec = load_task(task)  # unknown names and bad files fail here, with suggestions
        if spec.name in names:
            raise RoboLabError(f"--task: '{names[spec.name]}' and '{task}' are both the task {spec.name}; give it once")
        names[spec.name] = task
        if not is_task_file(task):
            resolved.append(spec.name)
            continue
        import robolab_ms.envs  # registers the known tasks first

        if spec.name in task_names() and robolab_ms.envs.registered_file(spec.env_id) != spec.file:
            print(
                f"robolab: note: {spec.file} replaces the task {spec.name} of "
                f"{robolab_ms.envs.registered_file(spec.env_id)} in this run; results are filed under its name",
                file=sys.stderr,
            )
        robolab_ms.envs.register_task_file(spec.file, replace=True)
        resolved.append(str(spec.file))
    return tuple(resolved)


def add_task_filters(parser: argparse.ArgumentParser) -> None:
    """The options that choose tasks by tag, difficulty and scene."""
    group = parser.add_argument_group(
        "task selection",
        "--task all takes every known task; these filters narrow --task (or all tasks when "
        "--task is not given). Different filters must all hold; several values of one mean any of them.",
    )
    group.add_argument(
        "--tag",
        nargs="+",
        metavar="TAG",
        help="attribute (color, semantics, size, conjunction, "
        "counting, spatial, affordance, reorientation, stacking, sorting, vague) or competency axis "
        "(visual, relational, procedural), e.g. --tag spatial",
    )
    group.add_argument("--difficulty", nargs="+", metavar="LEVEL", help="simple, moderate or complex")
    group.add_argument("--scene", nargs="+", metavar="SCENE", help="scene name, as in `robolab list`")


def select_tasks(args: argparse.Namespace) -> None:
    """Expand `--task all` and apply --tag / --difficulty / --scene: `args.task` becomes the chosen tasks."""
    from robolab_ms.tasks.selection import select_tasks as chosen_tasks

    args.task = chosen_tasks(getattr(args, "task", None), args.tag, args.difficulty, args.scene)


def vary_text(vary: list[str] | None) -> str | None:
    """The `--vary` settings as one checked text (None when not given)."""
    if not vary:
        return None
    from robolab_ms.variations import Variations

    return Variations.create(",".join(vary)).text or None


def print_aligned(rows: Sequence[Sequence[str]]) -> None:
    """Print rows of text cells as columns, each as wide as its widest cell."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        print("  ".join(cell.ljust(width) for cell, width in zip(row, widths)).rstrip())
