"""`robolab validate`: check tasks (stable at rest, not solved at reset or by chance, solved by the oracle)."""

from __future__ import annotations

import argparse
import sys

from robolab_ms.cli.common import TASK_HELP, task_arguments, vary_text
from robolab_ms.errors import RoboLabError
from robolab_ms.physics import MAX_DRIFT_M, STABILITY_PHYSICS_STEPS


def add_validate_command(commands, content: argparse.ArgumentParser) -> None:
    """Add `robolab validate` to the commands."""
    validate = commands.add_parser(
        "validate",
        parents=[content],
        help="check tasks: stable at rest, not solved at reset, not solved by chance, solved by the oracle",
        description=f"For each task over SEEDS seeds: the largest object drift over {STABILITY_PHYSICS_STEPS} physics "
        f"steps at rest (max {MAX_DRIFT_M * 100:.0f} cm), success right after reset (must be none), the random "
        "policy's success rate (max 10%) and the oracle's (min 90%) with its time per episode. Writes "
        "OUT/validation.csv and OUT/validation.md, the episodes to OUT/episodes.jsonl (a rerun resumes), and exits "
        "with status 1 when a task fails a check. With --workers N the checks and episodes of all tasks run in N "
        "processes (docs/scaling.md).",
    )
    validate.add_argument("--task", nargs="+", metavar="TASK", help=TASK_HELP)
    validate.add_argument("--all", action="store_true", help="validate every task")
    validate.add_argument("--seeds", type=int, default=10, help="seeds per task (default: 10)")
    validate.add_argument("--seed", type=int, default=0, help="first seed (default: 0)")
    validate.add_argument("--out", default="results/validate", help="results folder (default: results/validate)")
    validate.add_argument("--quiet", action="store_true", help="no progress bars")
    validate.add_argument(
        "--workers",
        type=int,
        default=1,
        metavar="N",
        help="run the rest checks and the random and oracle episodes of all tasks in N worker "
        "processes (as `robolab eval --workers`); this process alone writes OUT, the report rows "
        "stay in task order and the results are those of one process (default: 1, in this "
        "process, task after task)",
    )
    validate.add_argument(
        "--vary",
        action="append",
        metavar="SETTINGS",
        help="validate under domain randomization, as `robolab eval --vary` (e.g. objects=0.2)",
    )
    validate.set_defaults(run=_cmd_validate)


def _cmd_validate(args: argparse.Namespace) -> int:
    from robolab_ms.eval.validate import REPORT_CSV, validate_parallel, validate_task, write_report
    from robolab_ms.tasks.spec import task_names

    if args.seeds < 1:
        raise RoboLabError(f"--seeds must be at least 1, got {args.seeds}")
    if args.seed < 0:
        raise RoboLabError(f"--seed must be 0 or more (the seeds are --seed, --seed+1, ...), got {args.seed}")
    if args.workers < 1:
        raise RoboLabError(f"--workers must be at least 1, got {args.workers}")
    if not args.all and not args.task:
        raise RoboLabError("name the tasks to validate with --task NAME ..., or use --all")
    tasks = task_names() if args.all else list(task_arguments(args.task))
    from robolab_ms.errors import make_folder

    out = make_folder(args.out, "--out")
    rows = []
    try:
        if args.workers > 1:
            rows = validate_parallel(
                tasks,
                args.seeds,
                out,
                args.seed,
                args.workers,
                show_progress=not args.quiet,
                variations=vary_text(args.vary),
            )
        else:
            for task in tasks:
                rows.append(
                    validate_task(
                        task, args.seeds, out, args.seed, show_progress=not args.quiet, variations=vary_text(args.vary)
                    )
                )
                write_report(rows, out)  # after every task: an interrupted run keeps what it checked
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: finished episodes are kept in {out / 'episodes.jsonl'}; run the same command again "
            "to resume",
            file=sys.stderr,
        )
        return 130
    report = write_report(rows, out)
    print(report.read_text(), end="")
    for row in rows:
        if row.oracle_failures:
            print(f"why the oracle failed {row.task}: {row.oracle_failures}")
    print(f"report: {report} (and {out / REPORT_CSV}); episodes: {out / 'episodes.jsonl'}")
    failed = [row.task for row in rows if not row.passed]
    if failed:
        print(f"robolab: {len(failed)} task(s) failed validation: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0
