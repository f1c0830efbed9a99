"""The leaderboard's HTML pages: the front page and one page per task. Their style sheet and the script that sorts
tables are the files style.css and page.js beside this module, written inline into every page. Every value from
the results or the real-world file passes through `_esc`."""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from functools import cache
from importlib.resources import files
from typing import TYPE_CHECKING
from urllib.parse import quote

from robolab_ms.analysis.leaderboard.board import (
    INDEX_HTML,
    MARKDOWN,
    Leaderboard,
    interval_percent,
    number_text,
    value_text,
)
from robolab_ms.analysis.leaderboard.ranking import INTERVAL_NOTE, RANKING_RULE, Rate, task_policy_table
from robolab_ms.analysis.leaderboard.sim_to_real import CORRELATION_HEADERS, SimToReal, correlation_rows

if TYPE_CHECKING:
    import pandas as pd

    from robolab_ms.analysis.leaderboard.videos import VideoLink


TEXT_CLASS = ' class="text"'  # a left-aligned (text) cell


def _esc(value: object) -> str:
    return html.escape(str(value), quote=True)


def _href(path: str) -> str:
    """A relative link, percent-encoded and escaped for an attribute."""
    return _esc(quote(path, safe="/._-~"))


def _sort_key(value: float | None) -> str:
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else repr(float(value))


def _num_cell(value: float, digits: int = 2, extra: str = "") -> str:
    shown = number_text(value, digits)
    css = ' class="missing"' if shown == "-" else ""
    return f'<td data-sort="{_sort_key(value)}"{css}>{shown}{extra}</td>'


def _rate_cell(rate: Rate | None, bar: bool = False) -> str:
    if rate is None or rate.episodes == 0:
        return '<td data-sort="" class="missing">-</td>'
    low, high = rate.interval
    tip = f"{rate.successes}/{rate.episodes} episodes, 95 % interval {100 * low:.1f}-{100 * high:.1f} %"
    meter = (
        f'<span class="bar" aria-hidden="true"><span style="width:{100 * rate.value:.1f}%"></span></span>'
        if bar
        else ""
    )
    return (
        f'<td data-sort="{_sort_key(100 * rate.value)}" title="{_esc(tip)}">{meter}{100 * rate.value:.1f} '
        f'<span class="ci">{interval_percent(low, high)}</span></td>'
    )


@cache
def page_file(name: str) -> str:
    """The text of a file shipped beside this module: `style.css` (the pages' style) or `page.js` (sorts a table by
    the clicked header: data-sort values or the cell text, numbers as numbers, empty values last; a second click on
    the same header reverses the order)."""
    return files(__package__).joinpath(name).read_text(encoding="utf-8")


def _page(title: str, body: str) -> str:
    """A whole HTML page, its style and script inline, so that it reads from any folder without a server."""
    return (
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f'<meta name="viewport" content="width=device-width, initial-scale=1">\n<title>{_esc(title)}</title>\n'
        f"<style>\n{page_file('style.css')}</style>\n</head>\n<body>\n{body}\n"
        f"<script>\n{page_file('page.js')}</script>\n</body>\n"
        "</html>\n"
    )


def _head_row(headers: Sequence[tuple[str, bool]]) -> str:
    """A header row from (label, is_text) pairs; labels are escaped here."""
    cells = "".join(f'<th scope="col"{TEXT_CLASS if text else ""}>{_esc(label)}</th>' for label, text in headers)
    return f"<thead><tr>{cells}</tr></thead>"


def _table(table_id: str, head: str, rows: Sequence[str], sortable: bool = True) -> str:
    """A table (sortable by its headers unless told otherwise) in a box that scrolls sideways on narrow screens."""
    css = ' class="sortable"' if sortable else ""
    return f'<div class="scroll"><table{css} id="{table_id}">{head}<tbody>{"".join(rows)}</tbody></table></div>'


def index_html(board: Leaderboard, title: str) -> str:
    """The site's front page."""
    parts = [
        f"<header><h1>{_esc(title)}</h1>",
        f'<p class="lead">{len(board.ranking)} policies, {len(board.tasks)} tasks, '
        f"{int(board.ranking['episodes'].sum()) if len(board.ranking) else 0} episodes from "
        f"{_esc(', '.join(board.runs))}. "
        f'<a href="{MARKDOWN}">Markdown version</a>.</p></header>',
        f'<p class="rule">{_esc(RANKING_RULE)} Click a column header to sort by it.</p>',
    ]
    parts += [f'<p class="note">{_esc(note)}</p>' for note in board.notes]
    headers = [("Rank", False), ("Policy", True), ("Success %", False)]
    headers += [(value.capitalize(), False) for value in board.axes]
    headers += [(value.capitalize(), False) for value in board.difficulties]
    headers += [("Score", False), ("Score(fail)", False), ("Episodes", False), ("Tasks", False)]
    rows = []
    for row in board.ranking.itertuples(index=False):
        cells = [
            f'<td data-sort="{row.rank}">{row.rank}</td>',
            f'<td class="name">{_esc(row.policy)}</td>',
            _rate_cell(Rate(row.successes, row.episodes), bar=True),
        ]
        cells += [_rate_cell(rates.get(row.policy)) for rates in board.axes.values()]
        cells += [_rate_cell(rates.get(row.policy)) for rates in board.difficulties.values()]
        cells += [_num_cell(row.score), _num_cell(row.score_fail), _num_cell(row.episodes, 0), _num_cell(row.tasks, 0)]
        rows.append(f"<tr>{''.join(cells)}</tr>")
    parts.append(
        '<h2>Policies</h2>\n<p class="lead">Success % per competency axis (columns after Success %) and '
        "per difficulty, with the 95 % interval in brackets.</p>"
    )
    parts.append(_table("ranking", _head_row(headers), rows))
    parts.append(_task_matrix_html(board))
    if board.sim_to_real is not None:
        parts.append(_sim_to_real_html(board.sim_to_real))
    parts.append(f"<footer><p>{_esc(INTERVAL_NOTE)}</p><p>Written by <code>robolab leaderboard</code>.</p></footer>")
    return _page(title, "\n".join(parts))


def _task_matrix_html(board: Leaderboard) -> str:
    policies = list(board.ranking["policy"])
    headers = [("Task", True), ("Difficulty", True), ("Axes", True)] + [(p, False) for p in policies]
    rows = []
    for task in board.tasks.itertuples(index=False):
        cells = [
            f'<td class="text"><a href="{_href(board.task_pages[task.task])}">{_esc(task.task)}</a></td>',
            f'<td class="text">{_esc(value_text(task.difficulty))}</td>',
            f'<td class="text">{_esc(value_text(task.axes).replace(";", ", "))}</td>',
        ]
        cells += [_rate_cell(board.task_rates.get((task.task, policy))) for policy in policies]
        rows.append(f"<tr>{''.join(cells)}</tr>")
    return (
        '<h2>Tasks</h2>\n<p class="lead">Success % per task and policy; a task\'s page has its scores, times, '
        "trajectory metrics and videos.</p>\n" + _table("tasks", _head_row(headers), rows)
    )


def _sim_to_real_html(comparison: SimToReal) -> str:
    parts = [
        '<h2 id="sim-to-real">Sim to real</h2>',
        '<p class="lead">Overall simulated success against the success measured on the real robot, for the '
        "policies in both. Fisher z intervals use 1/sqrt(n-3) (Pearson) and sqrt(1.06/(n-3)) (Spearman); the "
        "bootstrap resamples policies.</p>",
    ]
    parts += [f'<p class="note">{_esc(note)}</p>' for note in comparison.notes]
    head = _head_row([(h, i in (0, 6)) for i, h in enumerate(CORRELATION_HEADERS)])
    body = "".join(
        "<tr>" + "".join(f"<td{TEXT_CLASS if i in (0, 6) else ''}>{_esc(v)}</td>" for i, v in enumerate(row)) + "</tr>"
        for row in correlation_rows(comparison)
    )
    parts.append(_table("correlation", head, [body], sortable=False))
    rows = []
    for row in comparison.table.itertuples(index=False):
        trials = row.real_episodes
        known = isinstance(trials, (int, float)) and not math.isnan(trials)
        real_rate = Rate(round(row.real * trials), int(trials)) if known else None
        real_cell = _rate_cell(real_rate) if real_rate else _num_cell(100 * row.real, 1)
        rows.append(
            f'<tr><td class="name">{_esc(row.policy)}</td>'
            f'<td data-sort="{_sort_key(100 * row.sim)}">{100 * row.sim:.1f} <span class="ci">'
            f"{interval_percent(row.sim_low, row.sim_high)}</span></td>{real_cell}</tr>"
        )
    head = _head_row([("Policy", True), ("Sim success %", False), ("Real success %", False)])
    parts.append(_table("sim-real", head, rows))
    if comparison.plot_files:
        png = next(name for name in comparison.plot_files if name.endswith(".png"))
        svg = next((name for name in comparison.plot_files if name.endswith(".svg")), png)
        parts.append(
            f'<p><a href="{_href(svg)}"><img class="plot" src="{_href(png)}" alt="real against simulated '
            'success, one point per policy"></a></p>'
        )
    return "\n".join(parts)


def task_html(
    board: Leaderboard, task: str, episodes: pd.DataFrame, links: dict[tuple[str, str], list[VideoLink]], title: str
) -> str:
    """One task's page: what it asks, and per policy its outcome, times, trajectory metrics and videos."""
    info = board.tasks.set_index("task").loc[task]
    instructions = episodes.drop_duplicates("instruction_variant").sort_values("instruction_variant")[
        ["instruction_variant", "instruction"]
    ]
    facts = [
        ("Scene", value_text(info["scene"])),
        ("Difficulty", value_text(info["difficulty"])),
        ("Axes", value_text(info["axes"]).replace(";", ", ")),
        ("Attributes", value_text(info["attributes"]).replace(";", ", ")),
    ]
    facts += [(f"Instruction ({variant})", value_text(text)) for variant, text in instructions.itertuples(index=False)]
    parts = [
        f'<p><a href="../{INDEX_HTML}">&larr; {_esc(title)}</a></p>',
        f"<h1>{_esc(task)}</h1>",
        '<dl class="facts">' + "".join(f"<dt>{_esc(k)}</dt><dd>{_esc(v) or '-'}</dd>" for k, v in facts) + "</dl>",
    ]
    table = task_policy_table(board.per_task, task, list(board.ranking["policy"]))
    rank_of = dict(zip(board.ranking["policy"], board.ranking["rank"]))
    headers = [
        ("Rank", False),
        ("Policy", True),
        ("Success %", False),
        ("Score", False),
        ("Score(fail)", False),
        ("Time to success (s)", False),
        ("SPARC", False),
        ("Path (cm)", False),
        ("Speed (cm/s)", False),
        ("Episodes", False),
        ("Videos", True),
    ]
    rows = []
    for row in table.itertuples(index=False):
        videos = links.get((row.policy, task), [])
        video_cell = (
            " ".join(
                f'<a class="{"ok" if v.success else "fail"}" href="../{_href(v.href)}">{_esc(v.label)}</a>'
                for v in videos
            )
            or '<span class="missing">none</span>'
        )
        cells = [
            f'<td data-sort="{rank_of[row.policy]}">{rank_of[row.policy]}</td>',
            f'<td class="name">{_esc(row.policy)}</td>',
            _rate_cell(Rate(row.successes, row.episodes), bar=True),
            _num_cell(row.score),
            _num_cell(row.score_fail),
            _num_cell(row.time_to_success_s, 1),
            _num_cell(row.ee_sparc),
            _num_cell(row.ee_path_cm, 1),
            _num_cell(row.ee_speed_mean_cm_s, 1),
            _num_cell(row.episodes, 0),
            f'<td class="text videos" data-sort="{len(videos)}">{video_cell}</td>',
        ]
        rows.append(f"<tr>{''.join(cells)}</tr>")
    parts.append(_table("policies", _head_row(headers), rows))
    parts.append(
        "<footer><p>Time to success: mean over the successful episodes. SPARC (smoothness, closer to 0 is "
        "smoother), path length and mean speed of the gripper: mean over the episodes. "
        f"{_esc(INTERVAL_NOTE)}</p></footer>"
    )
    return _page(f"{task} - {title}", "\n".join(parts))
