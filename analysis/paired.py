"""Paired comparison of two policies run on the same episodes (`robolab analyze ... --compare A B`).

Episodes are matched on (task, instruction variant, robot, seed): with the same seed both policies started from
the same scene, so each pair differs only by the policy. Per task:

- the difference in success rate, A - B, with a 95 % interval for a difference of paired proportions (Newcombe's
  hybrid score interval, his method 10: Wilson intervals of both rates combined through the correlation of the
  paired outcomes);
- the exact McNemar test: under "no difference" the pairs where only one policy succeeded are equally likely to
  be A's or B's, so the count of A-only pairs is Binomial(discordant pairs, 1/2); two-sided p-value.

Overall: the mean over tasks of the per-task differences, with a bootstrap interval that resamples tasks (seeded;
expanded percentile interval, see `bootstrap_mean_interval`), so it speaks for tasks like these rather than only
for these episodes. A task is won by the policy with the higher success rate there; a win is significant when
McNemar's p < 1 - level, both uncorrected and with Holm's correction over the tasks compared (family-wise error at
most 1 - level).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.stats import binom, norm
from scipy.stats import t as student_t

from robolab_ms.errors import RoboLabError, did_you_mean

MATCH_KEYS = ["task", "instruction_variant", "robot", "seed"]


@dataclass
class PairedComparison:
    """The result of `compare_policies`: `per_task` one row per task, `overall` the aggregate and the win counts."""

    a: str
    b: str
    per_task: pd.DataFrame
    overall: dict
    level: float


def resolve_pair(episodes: pd.DataFrame, names: Sequence[str]) -> tuple[str, str]:
    """The two sides of `--compare`: the names given, or the two policies of `episodes` when none are given."""
    if len(names) == 2:
        return names[0], names[1]
    policies = sorted(episodes["policy"].unique())
    if not names and len(policies) == 2:
        return policies[0], policies[1]
    if not names:
        raise RoboLabError(
            f"--compare without names needs exactly two policies; these runs hold {len(policies)} "
            f"({', '.join(policies)}): give two, e.g. --compare {' '.join(policies[:2])}"
        )
    raise RoboLabError(f"--compare takes two policy names, got {len(names)}: {' '.join(names)}")


def side_episodes(episodes: pd.DataFrame, policy: str) -> pd.DataFrame:
    """The episodes of one side of the comparison: those of `policy`."""
    chosen = episodes[episodes["policy"] == policy]
    if chosen.empty:
        known = set(episodes["policy"])
        raise RoboLabError(f"--compare {policy}: not a policy of these runs. {did_you_mean(policy, known)}")
    return chosen


def pair_outcomes(episodes: pd.DataFrame, a: str, b: str) -> tuple[pd.DataFrame, int, int]:
    """Matched pairs (MATCH_KEYS, `success_a`, `success_b`) and how many episodes of A and of B found no partner."""
    if a == b:
        raise RoboLabError(f"--compare {a} {b}: name two different policies")
    first, second = side_episodes(episodes, a), side_episodes(episodes, b)
    if "simulator" in episodes:
        simulators = {name: sorted(set(side["simulator"])) for name, side in ((a, first), (b, second))}
        if simulators[a] != simulators[b]:
            raise RoboLabError(
                f"--compare {a} {b}: {a} ran in {', '.join(simulators[a])} and {b} in {', '.join(simulators[b])}; "
                "the same seed does not start the same scene in two simulators, so their episodes do not pair. "
                "Compare them side by side instead: robolab analyze ... --by task,simulator"
            )
    pairs = first[MATCH_KEYS + ["success"]].merge(
        second[MATCH_KEYS + ["success"]], on=MATCH_KEYS, suffixes=("_a", "_b")
    )
    if pairs.empty:
        raise RoboLabError(
            f"--compare {a} {b}: no episode of {a} has a partner of {b} with the same task, instruction variant, "
            f"robot and seed ({a}: {_describe(first)}; {b}: {_describe(second)}); run both on the same tasks and "
            "seeds, e.g. `robolab eval --policy P --task ... --episodes N --seed 0` for each"
        )
    return pairs, len(first) - len(pairs), len(second) - len(pairs)


def compare_policies(
    episodes: pd.DataFrame, a: str, b: str, level: float = 0.95, resamples: int = 2000, seed: int = 0
) -> PairedComparison:
    """Per-task and overall differences A - B in success rate on matched episodes (see the module docstring)."""
    if resamples < 100:
        raise RoboLabError(f"--resamples {resamples}: give at least 100 (2000 is the default)")
    pairs, unmatched_a, unmatched_b = pair_outcomes(episodes, a, b)
    per_task = paired_task_table(pairs, level)
    alpha = 1.0 - level
    per_task["winner"] = np.where(per_task["difference_%"] > 0, a, np.where(per_task["difference_%"] < 0, b, "tie"))
    per_task["significant"] = per_task["p_mcnemar"] < alpha
    per_task["significant_holm"] = per_task["p_holm"] < alpha
    differences = per_task["difference_%"].to_numpy() / 100.0
    low, high = bootstrap_mean_interval(differences, level, resamples, seed)
    overall = {
        "a": a,
        "b": b,
        "pairs": int(per_task["pairs"].sum()),
        "tasks": len(per_task),
        "a_success_%": float(per_task["a_success_%"].mean()),
        "b_success_%": float(per_task["b_success_%"].mean()),
        "difference_%": 100.0 * float(differences.mean()),
        "ci_low_%": 100.0 * low,
        "ci_high_%": 100.0 * high,
        "level": level,
        "resamples": resamples,
        "seed": seed,
        "unmatched_a": unmatched_a,
        "unmatched_b": unmatched_b,
    }
    for side, name in (("a", a), ("b", b)):
        won = per_task["winner"] == name
        overall[f"{side}_wins"] = int(won.sum())
        overall[f"{side}_wins_significant"] = int((won & per_task["significant"]).sum())
        overall[f"{side}_wins_significant_holm"] = int((won & per_task["significant_holm"]).sum())
    overall["ties"] = int((per_task["winner"] == "tie").sum())
    return PairedComparison(a, b, per_task, overall, level)


def paired_task_table(pairs: pd.DataFrame, level: float = 0.95) -> pd.DataFrame:
    """One row per task of matched pairs: pairs, the four outcome counts, both success rates, the difference
    with its interval, the exact McNemar p-value and its Holm-adjusted value over the tasks."""
    a, b = pairs["success_a"].astype(bool), pairs["success_b"].astype(bool)
    counts = (
        pd.DataFrame({"task": pairs["task"], "both": a & b, "a_only": a & ~b, "b_only": ~a & b, "neither": ~a & ~b})
        .groupby("task", sort=True)
        .sum()
        .astype(int)
    )
    both, a_only, b_only, neither = (counts[c].to_numpy() for c in ("both", "a_only", "b_only", "neither"))
    total = both + a_only + b_only + neither
    low, high = paired_difference_interval(both, a_only, b_only, neither, level)
    table = pd.DataFrame(
        {
            "task": counts.index,
            "pairs": total,
            "a_success_%": 100.0 * (both + a_only) / total,
            "b_success_%": 100.0 * (both + b_only) / total,
            "difference_%": 100.0 * (a_only - b_only) / total,
            "ci_low_%": 100.0 * low,
            "ci_high_%": 100.0 * high,
            "both": both,
            "a_only": a_only,
            "b_only": b_only,
            "neither": neither,
            "p_mcnemar": mcnemar_exact(a_only, b_only),
        }
    )
    table["p_holm"] = holm_adjusted(table["p_mcnemar"].to_numpy())
    return table.reset_index(drop=True)


def mcnemar_exact(a_only: np.ndarray, b_only: np.ndarray) -> np.ndarray:
    """Two-sided exact McNemar p-values (vectorised): the A-only count among the m discordant pairs against
    Binomial(m, 1/2). The null distribution is symmetric, so the p-value is twice the smaller tail, at most 1 (the
    same as `scipy.stats.binomtest(a_only, m, 0.5).pvalue`); 1 without discordant pairs."""
    a_only, b_only = np.asarray(a_only, dtype=int), np.asarray(b_only, dtype=int)
    return np.minimum(1.0, 2.0 * binom.cdf(np.minimum(a_only, b_only), a_only + b_only, 0.5))


def holm_adjusted(p_values: np.ndarray) -> np.ndarray:
    """Holm's step-down adjusted p-values (reject where adjusted < alpha: family-wise error at most alpha)."""
    p = np.asarray(p_values, dtype=float)
    order = np.argsort(p)
    steps = (len(p) - np.arange(len(p))) * p[order]
    adjusted = np.empty_like(p)
    adjusted[order] = np.minimum(1.0, np.maximum.accumulate(steps))
    return adjusted


def wilson_interval(successes: np.ndarray, n: np.ndarray, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval of a proportion (vectorised)."""
    z = norm.ppf(0.5 + level / 2)
    rate = successes / n
    centre = (rate + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(rate * (1 - rate) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def paired_difference_interval(
    both: np.ndarray, a_only: np.ndarray, b_only: np.ndarray, neither: np.ndarray, level: float = 0.95
) -> tuple[np.ndarray, np.ndarray]:
    """Interval for p_A - p_B from paired binary outcomes (Newcombe 1998, method 10), vectorised over tasks."""
    both, a_only, b_only, neither = (np.asarray(x, dtype=float) for x in (both, a_only, b_only, neither))
    n = both + a_only + b_only + neither
    rate_a, rate_b = (both + a_only) / n, (both + b_only) / n
    low_a, high_a = wilson_interval(both + a_only, n, level)
    low_b, high_b = wilson_interval(both + b_only, n, level)
    spread = (both + a_only) * (b_only + neither) * (both + b_only) * (a_only + neither)
    correlation = np.where(spread > 0, (both * neither - a_only * b_only) / np.sqrt(np.maximum(spread, 1.0)), 0.0)
    below = np.sqrt(
        np.maximum(
            0.0, (rate_a - low_a) ** 2 - 2 * correlation * (rate_a - low_a) * (high_b - rate_b) + (high_b - rate_b) ** 2
        )
    )
    above = np.sqrt(
        np.maximum(
            0.0, (high_a - rate_a) ** 2 - 2 * correlation * (high_a - rate_a) * (rate_b - low_b) + (rate_b - low_b) ** 2
        )
    )
    difference = rate_a - rate_b
    return np.maximum(-1.0, difference - below), np.minimum(1.0, difference + above)


def bootstrap_mean_interval(
    values: np.ndarray, level: float = 0.95, resamples: int = 2000, seed: int = 0
) -> tuple[float, float]:
    """Bootstrap interval of the mean of `values` (one per task), resampling them with replacement: the expanded
    percentile interval (Hesterberg 2015), whose quantiles sit further out, by the factor
    sqrt(n / (n - 1)) t(n - 1) / z, so that few tasks do not give a too narrow interval; many tasks give nearly
    the plain percentile interval."""
    values = np.asarray(values, dtype=float)
    count = len(values)
    rng = np.random.default_rng(seed)
    means = values[rng.integers(0, count, size=(resamples, count))].mean(axis=1)
    tail = (1.0 - level) / 2
    if count > 1:
        tail = float(norm.cdf(-np.sqrt(count / (count - 1)) * student_t.ppf(1.0 - tail, count - 1)))
    return float(np.quantile(means, tail)), float(np.quantile(means, 1.0 - tail))


def comparison_markdown(comparison: PairedComparison) -> str:
    """The comparison as Markdown: the overall difference, the win counts and one row per task."""
    o, a, b = comparison.overall, comparison.a, comparison.b
    percent = round(100 * comparison.level)
    alpha = 1.0 - comparison.level
    lines = [
        f"## Paired comparison: {a} vs {b}\n",
        f"{o['pairs']} pairs on {o['tasks']} tasks, matched on task, instruction variant, robot and seed "
        f"(left out, no partner: {o['unmatched_a']} episodes of {a}, {o['unmatched_b']} of {b}).\n",
        f"- success, mean over tasks: {a} {o['a_success_%']:.1f} %, {b} {o['b_success_%']:.1f} %",
        f"- difference {a} - {b}: {o['difference_%']:+.1f} points, {percent} % bootstrap interval over tasks "
        f"[{o['ci_low_%']:+.1f}, {o['ci_high_%']:+.1f}] ({o['resamples']} resamples, seed {o['seed']})"
        + ("; with fewer than 10 tasks it is rough (docs/analysis.md)" if o["tasks"] < 10 else ""),
        f"- tasks won: {a} {o['a_wins']} ({o['a_wins_significant']} significant), {b} {o['b_wins']} "
        f"({o['b_wins_significant']} significant), tied {o['ties']}. Significant: exact McNemar p < {alpha:g}, "
        f"two-sided, not corrected for the {o['tasks']} tests; with Holm's correction: {a} "
        f"{o['a_wins_significant_holm']}, {b} {o['b_wins_significant_holm']}\n",
        f"| task | pairs | {a} % | {b} % | difference [{percent} % CI] | {a} only | {b} only | p McNemar | p Holm | "
        "winner |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|---|",
    ]
    for _, row in comparison.per_task.iterrows():
        mark = "*" if row["significant"] else ""
        lines.append(
            f"| {row['task']} | {row['pairs']} | {row['a_success_%']:.0f} | {row['b_success_%']:.0f} | "
            f"{row['difference_%']:+.0f} [{row['ci_low_%']:+.0f}, {row['ci_high_%']:+.0f}] | {row['a_only']} | "
            f"{row['b_only']} | {row['p_mcnemar']:.3g} | {row['p_holm']:.3g} | {row['winner']}{mark} |"
        )
    lines.append(
        f"\n\\* significant at {alpha:g} before correction. Difference interval per task: Newcombe's "
        "hybrid score interval for paired proportions.\n"
    )
    return "\n".join(lines) + "\n"


def _describe(frame: pd.DataFrame) -> str:
    tasks = sorted(frame["task"].unique())
    seeds = sorted(frame["seed"].unique())
    shown = ", ".join(tasks[:3]) + (", ..." if len(tasks) > 3 else "")
    return (
        f"{len(frame)} episodes, tasks {shown}, variants {', '.join(sorted(frame['instruction_variant'].unique()))}"
        f", robots {', '.join(sorted(frame['robot'].unique()))}, seeds {seeds[0]}..{seeds[-1]}"
    )
