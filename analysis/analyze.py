"""The `robolab analyze` command: options and what it prints and writes. Light to import (the CLI builds its
parser from it); the tables live in `robolab_ms.analysis.report`, the plots in `.plots`, the paired comparison in
`.paired`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from robolab_ms.errors import RoboLabError

DEFAULT_BINS = 5
TERMINAL_VIEWS = ("axis", "difficulty")
GROUPING_NAMES = (
    "task",
    "axis",
    "attribute",
    "difficulty",
    "scene",
    "variant",
    "num_objects",
    "episode_length",
    "wrong_objects",
    "robot",
    "run",
    "condition",
    "simulator",
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of `robolab analyze`."""
    parser.add_argument(
        "runs",
        nargs="+",
        metavar="RUN_DIR",
        help="results folders of `robolab eval --out DIR` "
        "(or synthetic ones); an episode in two folders counts once, from the folder given last",
    )
    chosen = parser.add_argument_group(
        "filters",
        "keep only some episodes; several values of one filter mean any of them, different filters must all hold",
    )
    chosen.add_argument("--task", nargs="+", metavar="TASK", help="task names")
    chosen.add_argument("--policy", nargs="+", metavar="POLICY", help="policy names")
    chosen.add_argument("--attribute", nargs="+", metavar="ATTR", help="task attributes, e.g. spatial color")
    chosen.add_argument("--axis", nargs="+", metavar="AXIS", help="competency axes: visual, relational, procedural")
    chosen.add_argument(
        "--where",
        action="append",
        default=[],
        metavar="COND",
        help="condition on any recorded field: FIELD=V[,V...], FIELD!=V, FIELD<N, <=, >, >=, e.g. "
        'light_color=red, "num_objects>=10", success=false, difficulty=complex; repeatable',
    )
    shown = parser.add_argument_group("tables")
    shown.add_argument(
        "--by",
        action="append",
        default=[],
        metavar="FIELD",
        help=f"groupings to show ({', '.join(GROUPING_NAMES)}, or any recorded field such as "
        "light_color; comma-separated, repeatable; `all`: every grouping and varied parameter); "
        "default: overall, axis, difficulty",
    )
    shown.add_argument(
        "--bins",
        type=int,
        default=DEFAULT_BINS,
        help=f"equal-count bins for numbers with more distinct values (default: {DEFAULT_BINS})",
    )
    shown.add_argument(
        "--out",
        metavar="DIR",
        help="write every table (CSV and Parquet), analysis.md and the plots (PNG and SVG) into DIR",
    )
    shown.add_argument("--no-plots", action="store_true", help="with --out: tables only")
    paired = parser.add_argument_group(
        "paired comparison", "two policies on the same episodes, matched on task, instruction variant, robot and seed"
    )
    paired.add_argument(
        "--compare", nargs="*", metavar="POLICY", help="A B: the two policies (no names: the two policies of the runs)"
    )
    paired.add_argument(
        "--resamples",
        type=int,
        default=2000,
        help="bootstrap resamples of the tasks for the overall interval (default: 2000)",
    )
    paired.add_argument("--seed", type=int, default=0, help="seed of the bootstrap (default: 0)")


def run(args: argparse.Namespace) -> int:
    """Print the tables (and the paired comparison); with --out write them and the plots."""
    from robolab_ms.analysis.report import (
        STANDARD_VIEWS,
        build_report,
        filter_episodes,
        parameter_columns,
        report_markdown,
        write_report,
    )
    from robolab_ms.analysis.runs import load_runs

    if args.bins < 1:
        raise RoboLabError(f"--bins {args.bins}: give at least 1")
    runs = load_runs(args.runs)
    episodes = filter_episodes(runs.episodes, args.task, args.policy, args.attribute, args.axis, args.where)
    views = _views(args.by, episodes)
    comparison = None
    if args.compare is not None:
        from robolab_ms.analysis.paired import compare_policies, resolve_pair

        first, second = resolve_pair(episodes, args.compare)
        comparison = compare_policies(episodes, first, second, resamples=args.resamples, seed=args.seed)
    print(_heading(runs.folders, episodes, args))
    print(report_markdown(build_report(episodes, views, args.bins), comparison))
    if args.out:
        every = list(dict.fromkeys([*STANDARD_VIEWS, *views, *parameter_columns(episodes)]))
        written = write_report(
            build_report(episodes, every, args.bins), Path(args.out), comparison, plots=not args.no_plots
        )
        print(f"robolab analyze: wrote {len(written)} files to {args.out}", file=sys.stderr)
    return 0


def _views(by: list[str], episodes) -> list[str]:
    """The groupings to print: those of --by (checked), or the default ones."""
    from robolab_ms.analysis.report import STANDARD_VIEWS, parameter_columns, resolve_field

    names = [name.strip() for text in by for name in text.split(",") if name.strip()]
    if not names:
        return list(TERMINAL_VIEWS)
    if "all" in names:
        names = [*STANDARD_VIEWS, *parameter_columns(episodes)]
    for name in names:
        resolve_field(episodes, name, "--by")
    return list(dict.fromkeys(names))


def _heading(folders, episodes, args: argparse.Namespace) -> str:
    policies = sorted(episodes["policy"].unique())
    text = (
        f"# robolab analyze\n\n{len(episodes)} episodes of {episodes['task'].nunique()} tasks, policies "
        f"{', '.join(policies)}; runs: {', '.join(str(folder) for folder in folders)}"
    )
    filters = [
        f"--{name} {' '.join(getattr(args, name))}"
        for name in ("task", "policy", "attribute", "axis")
        if getattr(args, name)
    ] + [f"--where {condition}" for condition in args.where]
    if filters:
        text += f"\nfilters: {'; '.join(filters)}"
    return text + "\n"
