"""Results tables derived from episode lines: success rate with its 95 % interval, score and Score(fail)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

import pandas as pd
from scipy.stats import beta

from robolab_ms.eval.results import EpisodeResult

SUMMARY_CSV = "summary.csv"
SUMMARY_MD = "summary.md"


def success_interval(successes: int, episodes: int, level: float = 0.95) -> tuple[float, float]:
    """Equal-tailed Bayesian interval of the success rate under a uniform prior: Beta(k + 1, n - k + 1)."""
    tail = (1 - level) / 2
    return (
        float(beta.ppf(tail, successes + 1, episodes - successes + 1)),
        float(beta.ppf(1 - tail, successes + 1, episodes - successes + 1)),
    )


def _summary_row(frame: pd.DataFrame) -> dict:
    episodes = len(frame)
    successes = int(frame["success"].sum())
    low, high = success_interval(successes, episodes)
    failed = frame[~frame["success"]]
    return {
        "episodes": episodes,
        "success_%": 100.0 * successes / episodes,
        "success_ci95_low_%": 100.0 * low,
        "success_ci95_high_%": 100.0 * high,
        "score": frame["score"].mean(),
        "score_fail": failed["score"].mean() if len(failed) else float("nan"),
        "progress": frame["progress"].mean(),
        "mean_steps": frame["steps"].mean(),
        "errors": int(frame["error"].notna().sum()),
    }


def summarize(results: Sequence[EpisodeResult]) -> pd.DataFrame:
    """One row per (policy, robot, task, instruction variant), then one 'ALL' row per policy and robot."""
    if not results:
        return pd.DataFrame()
    frame = pd.DataFrame([asdict(r) for r in results])
    keys = ["policy", "robot", "task", "instruction_variant"]
    rows = [{**dict(zip(keys, key)), **_summary_row(group)} for key, group in frame.groupby(keys, sort=True)]
    for (policy, robot), group in frame.groupby(["policy", "robot"], sort=True):
        rows.append({"policy": policy, "robot": robot, "task": "ALL", "instruction_variant": "all",
                     **_summary_row(group)})  # fmt: skip
    return pd.DataFrame(rows)


def to_markdown(table: pd.DataFrame) -> str:
    """A Markdown table with rounded numbers (percentages to 0.1, scores to 0.01)."""
    if table.empty:
        return "_no episodes yet_\n"
    shown = table.copy()
    for column in shown.columns:
        if column.endswith("_%"):
            shown[column] = shown[column].map(lambda v: f"{v:.1f}")
        elif column in ("score", "score_fail", "progress"):
            shown[column] = shown[column].map(lambda v: "-" if pd.isna(v) else f"{v:.2f}")
        elif column == "mean_steps":
            shown[column] = shown[column].map(lambda v: f"{v:.0f}")
    header = "| " + " | ".join(shown.columns) + " |"
    rule = "|" + "|".join("---" for _ in shown.columns) + "|"
    lines = ["| " + " | ".join(str(v) for v in row) + " |" for row in shown.itertuples(index=False)]
    return "\n".join([header, rule, *lines]) + "\n"


def write_summary(results: Sequence[EpisodeResult], out_dir: Path) -> pd.DataFrame:
    """Write summary.csv and summary.md into `out_dir`; returns the table."""
    table = summarize(results)
    table.to_csv(Path(out_dir) / SUMMARY_CSV, index=False)
    (Path(out_dir) / SUMMARY_MD).write_text(to_markdown(table), encoding="utf-8")
    return table
