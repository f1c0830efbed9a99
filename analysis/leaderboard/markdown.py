"""The leaderboard as one Markdown document, every value from the results Markdown-escaped."""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from typing import TYPE_CHECKING
from urllib.parse import quote

from robolab_ms.analysis.leaderboard.board import Leaderboard, interval_percent, number_text, value_text
from robolab_ms.analysis.leaderboard.ranking import INTERVAL_NOTE, RANKING_RULE, Rate, task_policy_table
from robolab_ms.analysis.leaderboard.sim_to_real import CORRELATION_HEADERS, PLOT_STEM, correlation_rows

if TYPE_CHECKING:
    import pandas as pd

    from robolab_ms.analysis.leaderboard.videos import VideoLink


def _md(value: object) -> str:
    """Text safe in a Markdown table cell: HTML-escaped, Markdown punctuation and pipes backslash-escaped."""
    text = html.escape(" ".join(str(value).split()), quote=False)
    return re.sub(r"([\\`*_\[\]|~])", r"\\\1", text)


def md_rate(rate: Rate | None) -> str:
    if rate is None or rate.episodes == 0:
        return "-"
    low, high = rate.interval
    return f"{100 * rate.value:.1f} {interval_percent(low, high)}"


def md_table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def leaderboard_markdown(
    board: Leaderboard, episodes: pd.DataFrame, links: dict[tuple[str, str], list[VideoLink]], title: str
) -> str:
    """The leaderboard as one Markdown document: ranking, tasks, per-task tables and sim to real."""
    parts = [
        f"# {_md(title)}\n\n",
        f"{len(board.ranking)} policies, {len(board.tasks)} tasks, from "
        f"{_md(', '.join(board.runs))}. {RANKING_RULE} {INTERVAL_NOTE}\n",
    ]
    parts += [f"\n> {_md(note)}\n" for note in board.notes]
    headers = ["Rank", "Policy", "Success %"] + [v.capitalize() for v in board.axes]
    headers += [v.capitalize() for v in board.difficulties] + ["Score", "Score(fail)", "Episodes", "Tasks"]
    rows = []
    for row in board.ranking.itertuples(index=False):
        cells = [str(row.rank), _md(row.policy), md_rate(Rate(row.successes, row.episodes))]
        cells += [md_rate(rates.get(row.policy)) for rates in board.axes.values()]
        cells += [md_rate(rates.get(row.policy)) for rates in board.difficulties.values()]
        cells += [number_text(row.score), number_text(row.score_fail), str(row.episodes), str(row.tasks)]
        rows.append(cells)
    parts += ["\n## Policies\n\n", md_table(headers, rows)]
    policies = list(board.ranking["policy"])
    rows = [
        [_md(t.task), _md(value_text(t.difficulty)), _md(value_text(t.axes).replace(";", ", "))]
        + [md_rate(board.task_rates.get((t.task, p))) for p in policies]
        for t in board.tasks.itertuples()
    ]
    task_headers = ["Task", "Difficulty", "Axes", *(_md(policy) for policy in policies)]
    parts += ["\n## Tasks (success %)\n\n", md_table(task_headers, rows)]
    headers = [
        "Policy",
        "Success %",
        "Score",
        "Score(fail)",
        "Time to success (s)",
        "SPARC",
        "Path (cm)",
        "Speed (cm/s)",
        "Episodes",
        "Videos",
    ]
    for task, _episodes_of_task in episodes.groupby("task", sort=True):
        table = task_policy_table(board.per_task, task, policies)
        rows = []
        for row in table.itertuples(index=False):
            videos = (
                " ".join(
                    f"[{_md(v.label)}{' ✓' if v.success else ''}]({quote(v.href, safe='/._-~')})"
                    for v in links.get((row.policy, str(task)), [])
                )
                or "-"
            )
            rows.append(
                [
                    _md(row.policy),
                    md_rate(Rate(row.successes, row.episodes)),
                    number_text(row.score),
                    number_text(row.score_fail),
                    number_text(row.time_to_success_s, 1),
                    number_text(row.ee_sparc),
                    number_text(row.ee_path_cm, 1),
                    number_text(row.ee_speed_mean_cm_s, 1),
                    str(row.episodes),
                    videos,
                ]
            )
        parts += [f"\n### {_md(task)}\n\n", md_table(headers, rows)]
    if board.sim_to_real is not None:
        comparison = board.sim_to_real
        parts.append("\n## Sim to real\n\n")
        parts += [f"> {_md(note)}\n\n" for note in comparison.notes]
        parts.append(md_table(CORRELATION_HEADERS, [[_md(v) for v in row] for row in correlation_rows(comparison)]))
        rows = [
            [_md(r.policy), f"{100 * r.sim:.1f} {interval_percent(r.sim_low, r.sim_high)}", f"{100 * r.real:.1f}"]
            for r in comparison.table.itertuples(index=False)
        ]
        parts += ["\n", md_table(["Policy", "Sim success %", "Real success %"], rows)]
        if comparison.plot_files:
            parts.append(f"\n![real against simulated success]({PLOT_STEM}.png)\n")
    return "".join(parts)
