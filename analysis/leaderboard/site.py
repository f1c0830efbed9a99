"""Writing the leaderboard site into a folder, and the `robolab leaderboard` command's options and run."""

from __future__ import annotations

import argparse
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from robolab_ms.analysis.leaderboard.board import (
    INDEX_HTML,
    MARKDOWN,
    TASK_DIR,
    Leaderboard,
    build_leaderboard,
    number_text,
)
from robolab_ms.analysis.leaderboard.markdown import leaderboard_markdown, md_rate, md_table
from robolab_ms.analysis.leaderboard.pages import index_html, task_html
from robolab_ms.analysis.leaderboard.ranking import Rate
from robolab_ms.analysis.leaderboard.sim_to_real import (
    PLOT_STEM,
    RealWorldResult,
    interval_text,
    plot_sim_to_real,
    read_real_world,
)
from robolab_ms.analysis.leaderboard.videos import VIDEO_DIR, VIDEO_MODES, collect_videos
from robolab_ms.errors import RoboLabError, make_folder

if TYPE_CHECKING:
    from robolab_ms.analysis.runs import RunSet


SITE_MARKER = ".robolab-leaderboard"  # marks a folder as a site this command wrote (and may rewrite)


def write_site(
    runs: RunSet,
    out: str | Path,
    real_world: Sequence[RealWorldResult] | None = None,
    videos: str = "copy",
    title: str = "RoboLab leaderboard",
) -> Leaderboard:
    """Write the leaderboard site and its Markdown copy into `out` (the layout: `robolab_ms.analysis.leaderboard`'s
    docstring)."""
    if videos not in VIDEO_MODES:
        raise RoboLabError(f"videos mode '{videos}': give one of {', '.join(VIDEO_MODES)}")
    site = _prepare_site(Path(out))
    board = build_leaderboard(runs, real_world)
    links = collect_videos(runs, site, videos)
    if board.sim_to_real is not None:
        board.sim_to_real.plot_files = plot_sim_to_real(board.sim_to_real, site)
    (site / INDEX_HTML).write_text(index_html(board, title), encoding="utf-8")
    (site / TASK_DIR).mkdir(exist_ok=True)
    for task, group in runs.episodes.groupby("task", sort=True):
        page = site / board.task_pages[str(task)]
        page.write_text(task_html(board, str(task), group, links, title), encoding="utf-8")
    (site / MARKDOWN).write_text(leaderboard_markdown(board, runs.episodes, links, title), encoding="utf-8")
    return board


def _prepare_site(site: Path) -> Path:
    """Create the site folder, or empty an earlier leaderboard's files from it; refuse any other non-empty folder."""
    if site.exists() and not site.is_dir():
        raise RoboLabError(f"{site}: exists and is not a folder; give a new or empty folder to --out")
    if site.is_dir() and any(site.iterdir()) and not (site / SITE_MARKER).exists():
        raise RoboLabError(
            f"{site}: not empty and not a leaderboard site written by `robolab leaderboard`; give a "
            "new or empty folder to --out"
        )
    make_folder(site, "--out")
    for name in (TASK_DIR, VIDEO_DIR):
        shutil.rmtree(site / name, ignore_errors=True)
    for name in (INDEX_HTML, MARKDOWN, PLOT_STEM + ".png", PLOT_STEM + ".svg"):
        (site / name).unlink(missing_ok=True)
    (site / SITE_MARKER).write_text(
        "written by robolab leaderboard; the command may empty this folder\n", encoding="utf-8"
    )
    return site


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR", help="results folders written by `robolab eval --out`")
    parser.add_argument(
        "--out",
        required=True,
        metavar="SITE_DIR",
        help="folder for the site (index.html, tasks/, leaderboard.md); new, empty, or an earlier "
        "leaderboard site (rewritten)",
    )
    parser.add_argument(
        "--real-world",
        metavar="FILE.csv",
        help="real-robot success per policy (columns policy, success; optional episodes): adds the "
        "sim-to-real comparison (Pearson and Spearman with intervals, scatter plot)",
    )
    parser.add_argument(
        "--videos",
        choices=VIDEO_MODES,
        default="copy",
        help="episode videos: copy them into the site (default; the folder works when moved), link "
        "to them in the results folders (relative links), or leave them out",
    )
    parser.add_argument("--title", default="RoboLab leaderboard", help="the site's title")


def run(args: argparse.Namespace) -> int:
    """Write the site and print the ranking."""
    from robolab_ms.analysis.runs import load_runs

    real_world = read_real_world(args.real_world) if args.real_world else None
    runs = load_runs(args.runs)
    board = write_site(runs, args.out, real_world, args.videos, args.title)
    site = Path(args.out)
    headers = ["Rank", "Policy", "Success %", "Score", "Episodes"]
    rows = [
        [str(r.rank), r.policy, md_rate(Rate(r.successes, r.episodes)), number_text(r.score), str(r.episodes)]
        for r in board.ranking.itertuples(index=False)
    ]
    print(md_table(headers, rows), end="")
    if board.sim_to_real is not None:
        for corr in (board.sim_to_real.pearson, board.sim_to_real.spearman):
            value = (
                "-"
                if corr.r is None
                else (f"{corr.r:+.2f} (Fisher {interval_text(corr.fisher)}, bootstrap {interval_text(corr.bootstrap)})")
            )
            note = f"; {corr.note}" if corr.note else ""
            print(f"sim to real, {corr.method} over {corr.n} policies: {value}{note}")
    print(f"wrote {site / INDEX_HTML}, {len(board.task_pages)} task pages and {site / MARKDOWN}")
    return 0
