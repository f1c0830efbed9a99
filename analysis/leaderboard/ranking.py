"""Ranking the policies of results folders, and their success per group and task, with 95 % intervals."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd


RANKING_RULE = (
    "Ranked by overall success rate (successes / episodes over all of a policy's episodes), ties by "
    "mean score, then by name; equal rate and score share a rank."
)


INTERVAL_NOTE = (
    "Intervals: 95 % equal-tailed Bayesian interval of the success rate under a uniform prior, "
    "Beta(k + 1, n - k + 1). Score: mean graded score (1 for a success); Score(fail): mean over the "
    "failed episodes."
)


@dataclass(frozen=True)
class Rate:
    """Successes out of episodes, with the 95 % Beta interval of the rate."""

    successes: int
    episodes: int

    @property
    def value(self) -> float:
        return self.successes / self.episodes if self.episodes else math.nan

    @property
    def interval(self) -> tuple[float, float]:
        from robolab_ms.analysis.tables import success_interval

        return success_interval(self.successes, self.episodes)


TASK_COLUMNS = (
    "policy",
    "task",
    "episodes",
    "successes",
    "score",
    "score_fail",
    "time_to_success_s",
    "ee_sparc",
    "ee_path_cm",
    "ee_speed_mean_cm_s",
)


def rank_policies(episodes: pd.DataFrame) -> pd.DataFrame:
    """One row per policy in rank order (RANKING_RULE): rank, policy, episodes, successes, tasks,
    success (0..1), success_low, success_high, score, score_fail. Numbers from `report.breakdown`."""
    from robolab_ms.analysis.report import breakdown
    from robolab_ms.analysis.tables import success_interval

    table = breakdown(episodes)[["policy", "episodes", "successes", "score", "score_fail"]].copy()
    if table.empty:
        return table
    tasks = episodes.groupby("policy")["task"].nunique()
    table["tasks"] = [int(tasks[policy]) for policy in table["policy"]]
    table["policy"] = table["policy"].astype(str)
    table["success"] = table["successes"] / table["episodes"]
    intervals = [success_interval(int(k), int(n)) for k, n in zip(table["successes"], table["episodes"])]
    table["success_low"] = [low for low, _ in intervals]
    table["success_high"] = [high for _, high in intervals]
    table = table.sort_values(
        ["success", "score", "policy"], ascending=[False, False, True], na_position="last", kind="mergesort"
    ).reset_index(drop=True)
    ranks: list[int] = []
    for position, row in enumerate(table.itertuples(index=False)):
        previous = table.iloc[position - 1] if position else None
        tied = (
            previous is not None
            and row.success == previous["success"]
            and (row.score == previous["score"] or (math.isnan(row.score) and math.isnan(previous["score"])))
        )
        ranks.append(ranks[-1] if tied else position + 1)
    table.insert(0, "rank", ranks)
    return table


def group_rates(episodes: pd.DataFrame, grouping: str, order: Sequence[str] = ()) -> dict[str, dict[str, Rate]]:
    """Success per group and policy, {group: {policy: Rate}}, for a grouping of `report.breakdown` (`axis`,
    `difficulty`, ...); an episode counts under each axis of its task. Groups in `order` come first; empty when no
    episode has the grouping's column."""
    from robolab_ms.analysis.report import GROUPINGS, breakdown

    if episodes[GROUPINGS.get(grouping, grouping)].isna().all():
        return {}
    table = breakdown(episodes, grouping)
    table = table.assign(**{grouping: table[grouping].astype(str)})
    table = table[table[grouping] != ""]
    values = sorted(table[grouping].unique(), key=lambda v: (order.index(v) if v in order else len(order), v))
    rates: dict[str, dict[str, Rate]] = {value: {} for value in values}
    for row in table[["policy", grouping, "successes", "episodes"]].itertuples(index=False):
        rates[row[1]][str(row.policy)] = Rate(int(row.successes), int(row.episodes))
    return rates


def task_policy_table(per_task: pd.DataFrame, task: str, policy_order: Sequence[str]) -> pd.DataFrame:
    """The rows of one task in `per_task` (`report.breakdown(episodes, "task")`), policies in `policy_order`: episodes,
    successes, score, Score(fail), time to success (s, successes only), SPARC, path (cm), mean speed (cm/s)."""
    rows = per_task.loc[per_task["task"] == task, list(TASK_COLUMNS)]
    position = {policy: index for index, policy in enumerate(policy_order)}
    return rows.assign(policy=rows["policy"].astype(str)).sort_values("policy", key=lambda p: p.map(position))
