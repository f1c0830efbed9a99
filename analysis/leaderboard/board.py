"""What a leaderboard's pages show, computed once from the episodes; the site's file layout; the text forms of
numbers that its HTML and Markdown share."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from robolab_ms.analysis.leaderboard.ranking import Rate, group_rates, rank_policies
from robolab_ms.analysis.leaderboard.sim_to_real import RealWorldResult, SimToReal, compare_sim_to_real
from robolab_ms.analysis.leaderboard.videos import unique_slugs

if TYPE_CHECKING:
    import pandas as pd

    from robolab_ms.analysis.runs import RunSet


INDEX_HTML = "index.html"


MARKDOWN = "leaderboard.md"


TASK_DIR = "tasks"


@dataclass
class Leaderboard:
    """Everything the pages show, computed once from the episodes."""

    ranking: pd.DataFrame
    axes: dict[str, dict[str, Rate]]
    difficulties: dict[str, dict[str, Rate]]
    tasks: pd.DataFrame  # one row per task: task, scene, difficulty, axes, attributes (in task-name order)
    per_task: pd.DataFrame  # `report.breakdown(episodes, "task")`: one row per task and policy
    task_rates: dict[tuple[str, str], Rate]  # (task, policy) -> Rate
    task_pages: dict[str, str]  # task -> page path relative to the site
    runs: list[str]
    notes: list[str] = field(default_factory=list)
    sim_to_real: SimToReal | None = None


def build_leaderboard(runs: RunSet, real_world: Sequence[RealWorldResult] | None = None) -> Leaderboard:
    """Rank the policies of `runs` and break their success down by axis, difficulty and task."""
    from robolab_ms.analysis.report import breakdown
    from robolab_ms.tasks.spec import DIFFICULTIES

    episodes = runs.episodes
    ranking = rank_policies(episodes)
    tasks = (
        episodes.groupby("task", sort=True)
        .first()
        .reset_index()
        .reindex(columns=["task", "scene", "difficulty", "axes", "attributes"])
    )
    per_task = breakdown(episodes, "task")
    task_rates = {
        (str(row.task), str(row.policy)): Rate(int(row.successes), int(row.episodes))
        for row in per_task[["task", "policy", "successes", "episodes"]].itertuples()
    }
    slugs = unique_slugs(list(tasks["task"]))
    board = Leaderboard(
        ranking=ranking,
        axes=group_rates(episodes, "axis", ("visual", "relational", "procedural")),
        difficulties=group_rates(episodes, "difficulty", DIFFICULTIES),
        tasks=tasks,
        per_task=per_task,
        task_rates=task_rates,
        task_pages={task: f"{TASK_DIR}/{slugs[task]}.html" for task in tasks["task"]},
        runs=[str(label) for label in episodes["run"].unique()],
    )
    task_sets = {str(p): frozenset(g["task"]) for p, g in episodes.groupby("policy")}
    if len(set(task_sets.values())) > 1:
        counts = ", ".join(f"{p}: {len(t)}" for p, t in sorted(task_sets.items()))
        board.notes.append(
            f"The policies were not run on the same tasks ({counts} tasks), so their overall rates "
            "are not directly comparable; compare them per task below."
        )
    if runs.unknown_tasks:
        board.notes.append(
            f"No task file describes {', '.join(runs.unknown_tasks)}: they count in the overall "
            "rate but in no axis or difficulty column."
        )
    if real_world is not None:
        board.sim_to_real = compare_sim_to_real(ranking, real_world)
    return board


def interval_percent(low: float, high: float) -> str:
    """An interval of a rate in whole percent, rounded outwards (so it never looks narrower than it is)."""
    return f"[{math.floor(100 * low + 1e-9):.0f}, {math.ceil(100 * high - 1e-9):.0f}]"


def number_text(value: float, digits: int = 2) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def value_text(value: object) -> str:
    """A table value as text ('' for a missing one)."""
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)
