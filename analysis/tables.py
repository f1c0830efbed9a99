"""Results tables derived from episode lines: success rate with its 95 % interval, score and Score(fail),
trajectory metrics and event counts (mean and standard deviation over episodes), and one CSV per task.

Files written by `write_summary` into a results folder:
- `summary.csv`: one row per (policy, robot, task, instruction variant) and an `ALL` row per policy and robot;
  metric columns `<name>` (mean, episodes where the metric is undefined left out) and `<name>_sd`; event columns
  `<event type>` (mean count per episode) and `<event type>_sd`.
- `summary.md`: the same as three Markdown tables (outcomes, trajectory, events), numbers as mean +- sd.
- `tasks/<Task>.csv`: every episode of the task, one row each, with its metrics, event counts and files.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

import pandas as pd
from scipy.stats import beta

from robolab_ms.eval.metrics import event_tallies
from robolab_ms.eval.results import EpisodeResult
from robolab_ms.tasks.events import EVENT_TYPES

SUMMARY_CSV = "summary.csv"
SUMMARY_MD = "summary.md"
TASKS_DIR = "tasks"
KEYS = ["policy", "robot", "task", "instruction_variant"]
# (metric key in a result line, table column, factor): lengths and speeds are shown in cm and cm/s, like RoboLab
METRIC_COLUMNS = (
    ("ee_sparc", "ee_sparc", 1.0),
    ("joint_sparc_mean", "joint_sparc_mean", 1.0),
    ("ee_isj", "ee_isj_m2_s5", 1.0),
    ("joint_isj", "joint_isj_rad2_s5", 1.0),
    ("ee_path_length", "ee_path_cm", 100.0),
    ("ee_speed_mean", "ee_speed_mean_cm_s", 100.0),
    ("ee_speed_max", "ee_speed_max_cm_s", 100.0),
    ("joint_rmse_mean", "joint_rmse_mean_rad", 1.0),
    ("joint_tracking_max", "joint_tracking_max_rad", 1.0),
)
# the metrics of results-version-1 lines (eval.metrics.LEGACY_METRIC_NAMES): columns only where such lines are read
LEGACY_METRIC_COLUMNS = (
    ("ee_sparc_v1", "ee_sparc_v1", 1.0),
    ("joint_sparc_v1", "joint_sparc_v1", 1.0),
    ("ee_jerk_v1", "ee_jerk_v1_m2_s5", 1.0),
    ("joint_jerk_v1", "joint_jerk_v1_rad2_s5", 1.0),
    ("ee_path_length_v1", "ee_path_v1_cm", 100.0),
    ("ee_speed_mean_v1", "ee_speed_mean_v1_cm_s", 100.0),
    ("ee_speed_max_v1", "ee_speed_max_v1_cm_s", 100.0),
    ("joint_tracking_rmse_v1", "joint_tracking_rmse_v1_rad", 1.0),
)
OUTCOME_COLUMNS = (
    "episodes",
    "success_%",
    "success_ci95_low_%",
    "success_ci95_high_%",
    "score",
    "score_fail",
    "progress",
    "mean_steps",
    "errors",
)


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
        **_spread(frame, metric_columns(frame)),
        **_spread(frame, list(EVENT_TYPES)),
    }


def _spread(frame: pd.DataFrame, columns: list[str]) -> dict[str, float]:
    """Mean and standard deviation of each column, NaN left out (sd is NaN with fewer than two values)."""
    row = {}
    for column in columns:
        values = pd.to_numeric(frame[column], errors="coerce").dropna() if column in frame else pd.Series(dtype=float)
        row[column] = float(values.mean()) if len(values) else float("nan")
        row[f"{column}_sd"] = float(values.std(ddof=1)) if len(values) > 1 else float("nan")
    return row


def metric_columns(frame: pd.DataFrame) -> list[str]:
    """The metric columns a table of `frame` shows: every current one, and the version-1 ones `frame` has."""
    legacy = [column for _, column, _ in LEGACY_METRIC_COLUMNS if column in frame]
    return [column for _, column, _ in METRIC_COLUMNS] + legacy


def episode_frame(results: Sequence[EpisodeResult]) -> pd.DataFrame:
    """One row per episode: the result fields, one column per metric (table units) and per event type (count),
    and `objects_<event type>` listing the objects an object event fired for. Version-1 metrics get their
    `LEGACY_METRIC_COLUMNS` only when some episode has them."""
    rows = []
    legacy_present = {key for result in results for key in (result.metrics or {})}
    legacy = [entry for entry in LEGACY_METRIC_COLUMNS if entry[0] in legacy_present]
    for result in results:
        row = {
            key: value
            for key, value in asdict(result).items()
            if key not in ("metrics", "event_counts", "event_objects", "events", "variation")
        }
        row.update(getattr(result, "variation", None) or {})  # drawn variation parameters, one column each
        for key, column, factor in (*METRIC_COLUMNS, *legacy):
            value = (result.metrics or {}).get(key)
            row[column] = float("nan") if value is None else float(value) * factor
        if result.events or not result.event_counts:  # the ordered list: older lines have no tallies
            counts, objects = event_tallies(result.events)
        else:  # tallies without a list (a RoboLab run folder's line)
            counts, objects = result.event_counts, result.event_objects
        for kind in EVENT_TYPES:
            row[kind] = counts.get(kind, 0)
        for kind, names in objects.items():
            row[f"objects_{kind}"] = ";".join(names)
        row["events"] = len(result.events)
        rows.append(row)
    return pd.DataFrame(rows)


def summarize(results: Sequence[EpisodeResult]) -> pd.DataFrame:
    """One row per (policy, robot, task, instruction variant), then one 'ALL' row per policy and robot."""
    if not results:
        return pd.DataFrame()
    frame = episode_frame(results)
    keys = KEYS
    rows = [{**dict(zip(keys, key)), **_summary_row(group)} for key, group in frame.groupby(keys, sort=True)]
    for (policy, robot), group in frame.groupby(["policy", "robot"], sort=True):
        rows.append(
            {"policy": policy, "robot": robot, "task": "ALL", "instruction_variant": "all", **_summary_row(group)}
        )
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


def _mean_sd(table: pd.DataFrame, column: str, digits: int) -> pd.Series:
    def show(row: pd.Series) -> str:
        mean, sd = row[column], row[f"{column}_sd"]
        if pd.isna(mean):
            return "-"
        return f"{mean:.{digits}f}" + ("" if pd.isna(sd) else f" ± {sd:.{digits}f}")

    return table.apply(show, axis=1)


def summary_markdown(table: pd.DataFrame) -> str:
    """The summary as Markdown: outcomes, trajectory metrics and events (mean ± sd over episodes)."""
    if table.empty:
        return "_no episodes yet_\n"
    keys = table[KEYS]
    outcomes = pd.concat([keys, table[list(OUTCOME_COLUMNS)]], axis=1)
    trajectory = keys.copy()
    for column in metric_columns(table):
        trajectory[column] = _mean_sd(table, column, 1 if ("isj" in column or "jerk" in column) else 3)
    events = keys.copy()
    for kind in EVENT_TYPES:
        if table[kind].fillna(0).any():
            events[kind] = _mean_sd(table, kind, 2)
    parts = [
        "## Outcomes\n",
        to_markdown(outcomes),
        "\n## Trajectory (mean ± sd over episodes; SPARC: closer to 0 is smoother)\n",
        to_markdown(trajectory),
        "\n## Events (count per episode, mean ± sd)\n",
    ]
    parts.append(to_markdown(events) if len(events.columns) > len(KEYS) else "_no events_\n")
    return "".join(parts)


def write_task_csvs(results: Sequence[EpisodeResult], out_dir: Path) -> list[Path]:
    """Write `tasks/<Task>.csv` (one row per episode) for every task in `results`; returns the files."""
    frame = episode_frame(results)
    if frame.empty:
        return []
    folder = Path(out_dir) / TASKS_DIR
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for task, group in frame.groupby("task", sort=True):
        path = folder / f"{task}.csv"
        group.sort_values(["policy", "robot", "instruction_variant", "seed"]).to_csv(path, index=False)
        files.append(path)
    return files


def write_summary(results: Sequence[EpisodeResult], out_dir: Path) -> pd.DataFrame:
    """Write summary.csv, summary.md and the per-task CSVs into `out_dir`; returns the summary table."""
    table = summarize(results)
    table.to_csv(Path(out_dir) / SUMMARY_CSV, index=False)
    (Path(out_dir) / SUMMARY_MD).write_text(summary_markdown(table), encoding="utf-8")
    write_task_csvs(results, out_dir)
    return table
