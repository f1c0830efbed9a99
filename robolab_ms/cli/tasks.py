"""`robolab list`: the tasks with their attributes and difficulty, or the benchmark's totals next to RoboLab-120's."""

from __future__ import annotations

import argparse

from robolab_ms.cli.common import TASK_HELP, add_task_filters, print_aligned, select_tasks
from robolab_ms.errors import RoboLabError


def add_list_command(commands, content: argparse.ArgumentParser) -> None:
    """Add `robolab list` to the commands."""
    listing = commands.add_parser("list", help="list the tasks with their attributes and difficulty", parents=[content])
    listing.add_argument("--task", nargs="+", metavar="TASK", help=TASK_HELP + " (default: every known task)")
    listing.add_argument(
        "--summary",
        action="store_true",
        help="print the benchmark's totals next to RoboLab-120's, with the difference: tasks, "
        "scenes, tasks per attribute, competency axis, difficulty and episode length, and objects "
        "per task (the objects of the task's scene a policy sees: targets, distractors, containers "
        "and fixtures, not the table or the robot's stand); then RoboLab's tasks still missing and "
        "each task whose facts differ from RoboLab's. Filters apply to both sides, RoboLab's by its "
        "own attributes, difficulty and scene",
    )
    listing.add_argument(
        "--format",
        choices=("text", "csv", "markdown"),
        default="text",
        help="with --summary: aligned text (default), CSV or Markdown tables",
    )
    add_task_filters(listing)
    listing.set_defaults(run=_cmd_list)


def _cmd_list(args: argparse.Namespace) -> int:
    if args.format != "text" and not args.summary:
        raise RoboLabError(f"--format {args.format} applies to the totals: add --summary")
    named = None if not args.task or "all" in args.task else list(args.task)  # before the filters narrow it
    select_tasks(args)
    from robolab_ms.content import content_dirs
    from robolab_ms.tasks.spec import load_all_tasks, load_task

    tasks = [load_task(task) for task in args.task] if args.task else load_all_tasks()
    if args.summary:
        from robolab_ms.tasks.summary import listing_summary, render

        print(render(listing_summary(tasks, named, args.tag, args.difficulty, args.scene), args.format), end="")
        return 0
    rows = [("task", "env id", "scene", "attributes", "axes", "subtasks", "difficulty", "seconds")]
    for spec in tasks:
        rows.append(
            (
                spec.name,
                spec.env_id,
                spec.scene.name,
                ",".join(spec.attributes) or "-",
                ",".join(spec.axes) or "-",
                str(spec.num_subtasks),
                f"{spec.difficulty} ({spec.difficulty_score})",
                f"{spec.episode_seconds:g}",
            )
        )
    print_aligned(rows)
    print(f"\n{len(tasks)} task(s)")
    if not args.task:
        print("task folders: " + ", ".join(str(folder.resolve()) for folder in content_dirs("tasks")))
    return 0
