"""`robolab analyze`: how often and how well policies succeed, broken down by what the tasks ask of them.

Tables group the episodes of `load_runs` (one row per episode) by a *grouping*, always per policy:

| grouping | column it reads | notes |
|---|---|---|
| `task` | `task` | rows also carry the task's scene, difficulty, difficulty score, axes, attributes |
| `axis`, `attribute` | `axes`, `attributes` | `;`-lists: an episode counts once under each of its values |
| `difficulty` | `difficulty` | simple, moderate, complex in that order |
| `scene`, `variant`, `robot`, `run`, `condition` | `scene`, `instruction_variant`, `robot`, `run`, `condition` | |
| `simulator` | `simulator` | robolab_ms, or robolab-isaac for episodes of a RoboLab run folder |
| `num_objects` | `num_objects` | bodies in the task's scene |
| `episode_length` | `episode_seconds` | the task's time limit in seconds |
| `wrong_objects` | `wrong_object_grasped` | wrong objects grasped in the episode: 0, 1, 2, 3+ |
| any other column | itself | numbers with more than `bins` distinct values are cut into `bins` equal-count bins |

Every table has the columns of `OUTCOME_COLUMNS`, `METRIC_COLUMNS` (and `LEGACY_METRIC_COLUMNS` where the episodes
have them) and one per event type (mean count per episode). Filters (`filter_episodes`) keep episodes by task, policy, attribute, axis and conditions on any column
(`Condition`, e.g. `light_color=red`, `num_objects>=10`).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pandas as pd

from robolab_ms.analysis.analyze import DEFAULT_BINS
from robolab_ms.analysis.runs import TASK_COLUMNS, explode_column
from robolab_ms.analysis.tables import LEGACY_METRIC_COLUMNS as _LEGACY_METRIC_SOURCES
from robolab_ms.analysis.tables import METRIC_COLUMNS as _METRIC_SOURCES
from robolab_ms.analysis.tables import metric_columns, success_interval
from robolab_ms.errors import RoboLabError, did_you_mean, make_folder
from robolab_ms.eval.results import EpisodeResult
from robolab_ms.tasks.events import EVENT_TYPES
from robolab_ms.tasks.spec import DIFFICULTIES

LIST_COLUMNS = ("axes", "attributes")
# grouping name -> the episode column it reads
GROUPINGS = {
    "task": "task",
    "axis": "axes",
    "attribute": "attributes",
    "difficulty": "difficulty",
    "scene": "scene",
    "variant": "instruction_variant",
    "num_objects": "num_objects",
    "episode_length": "episode_seconds",
    "wrong_objects": "wrong_object_grasped",
    "robot": "robot",
    "run": "run",
    "condition": "condition",
    "simulator": "simulator",
}
STANDARD_VIEWS = (
    "task",
    "axis",
    "attribute",
    "difficulty",
    "scene",
    "variant",
    "num_objects",
    "episode_length",
    "wrong_objects",
)
OUTCOME_COLUMNS = (
    "episodes",
    "successes",
    "success_%",
    "success_ci95_low_%",
    "success_ci95_high_%",
    "score",
    "score_fail",
    "progress",
    "time_to_success_s",
    "errors",
)
METRIC_COLUMNS = tuple(column for _, column, _ in _METRIC_SOURCES)
LEGACY_METRIC_COLUMNS = tuple(column for _, column, _ in _LEGACY_METRIC_SOURCES)
TASK_DETAIL_COLUMNS = (
    "scene",
    "difficulty",
    "difficulty_score",
    "num_subtasks",
    "num_objects",
    "episode_seconds",
    "axes",
    "attributes",
)
UNKNOWN = "(unknown)"


# ---------------------------------------------------------------------------------------------------------------
# Tables


def breakdown(
    episodes: pd.DataFrame, by: str | Sequence[str] = (), per_policy: bool = True, bins: int = DEFAULT_BINS
) -> pd.DataFrame:
    """One row per policy and group of `by` (grouping names or episode columns, see the module docstring; none:
    one row per policy) with episodes, successes, success % and its 95 % Beta interval, score, Score(fail),
    progress, time to success (mean over successes), errors, the trajectory metrics (means) and the event types
    (mean count per episode). Binned numeric groups also get `<name>_mean`, the mean value in the bin."""
    names = [by] if isinstance(by, str) else list(by)
    frame = episodes
    keys = ["policy"] if per_policy else []
    binned = []
    for name in names:
        frame, is_binned = group_column(frame, name, bins)
        keys.append(name)
        if is_binned:
            binned.append(name)
    rows = []
    groups = frame.groupby(keys, sort=True, observed=True, dropna=False) if keys else [((), frame)]
    for key, group in groups:
        key = key if isinstance(key, tuple) else (key,)
        row = dict(zip(keys, key))
        if "task" in names:
            row.update({column: _first(group, column) for column in TASK_DETAIL_COLUMNS if column in group})
        for name in binned:
            row[f"{name}_mean"] = float(pd.to_numeric(group[f"_{name}_value"]).mean())
        row.update(outcome_row(group))
        rows.append(row)
    columns = None if rows else [*keys, *OUTCOME_COLUMNS, *METRIC_COLUMNS, *EVENT_TYPES]
    return pd.DataFrame(rows, columns=columns)


def outcome_row(frame: pd.DataFrame) -> dict:
    """The outcome, metric and event columns of one group of episodes."""
    episodes = len(frame)
    successes = int(frame["success"].sum())
    low, high = success_interval(successes, episodes)
    failed = frame.loc[~frame["success"].astype(bool), "score"]
    row = {
        "episodes": episodes,
        "successes": successes,
        "success_%": 100.0 * successes / episodes,
        "success_ci95_low_%": 100.0 * low,
        "success_ci95_high_%": 100.0 * high,
        "score": float(frame["score"].mean()),
        "score_fail": float(failed.mean()) if len(failed) else float("nan"),
        "progress": float(frame["progress"].mean()),
        "time_to_success_s": _mean(frame, "time_to_success_s"),
        "errors": int(frame["error"].notna().sum()) if "error" in frame else 0,
    }
    row.update({column: _mean(frame, column) for column in metric_columns(frame)})
    row.update({kind: _mean(frame, kind) for kind in EVENT_TYPES})
    return row


def group_column(episodes: pd.DataFrame, name: str, bins: int = DEFAULT_BINS) -> tuple[pd.DataFrame, bool]:
    """`episodes` with a column `name` holding each episode's group (rows repeated for `;`-list columns), and
    whether the groups are bins of a number (then `_<name>_value` keeps the number)."""
    column = resolve_field(episodes, name, "--by")
    if column in LIST_COLUMNS:
        frame = explode_column(episodes, column)
        return frame.assign(**{name: frame[column]}), False
    values = episodes[column]
    if column == "difficulty":
        grouped = pd.Categorical(values.fillna(UNKNOWN), categories=[*DIFFICULTIES, UNKNOWN], ordered=True)
        return episodes.assign(**{name: grouped}), False
    if column == "wrong_object_grasped":
        labels = ["0", "1", "2", "3+"]
        counts = pd.to_numeric(values, errors="coerce").fillna(0).clip(upper=3).astype(int)
        grouped = pd.Categorical([labels[count] for count in counts], categories=labels, ordered=True)
        return episodes.assign(**{name: grouped}), False
    numeric = _numeric(values)
    if numeric is not None and values.nunique(dropna=True) > bins:
        return episodes.assign(**{name: equal_count_bins(numeric, bins), f"_{name}_value": numeric}), True
    if numeric is None and values.dtype == object:
        values = values.map(_group_label)
    return episodes.assign(**{name: values}), False


def _group_label(value: object) -> object:
    """A value as a group: missing ones as UNKNOWN, nested ones (policy metadata) as their JSON text."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return UNKNOWN
    if isinstance(value, (dict, list)):
        return json.dumps(value, sort_keys=True, default=str)
    return value


def equal_count_bins(values: pd.Series, bins: int) -> pd.Categorical:
    """Cut numbers into up to `bins` bins holding about as many values each, labelled `[low, high]`."""
    finite = values.dropna()
    edges = np.unique(np.quantile(finite, np.linspace(0, 1, bins + 1)))
    if len(edges) < 2:
        edges = np.array([finite.min(), finite.max() + 1e-12])
    labels = [f"[{_short(low)}, {_short(high)}]" for low, high in zip(edges[:-1], edges[1:])]
    return pd.cut(values, edges, labels=labels, include_lowest=True, ordered=True, duplicates="drop")


def parameter_columns(episodes: pd.DataFrame) -> list[str]:
    """The drawn variation parameters recorded in `episodes` (docs/variations.md), those that vary, sorted."""
    fixed = {f.name for f in fields(EpisodeResult)} | {
        "run",
        "events",
        "time_to_success_s",
        *TASK_COLUMNS,
        *METRIC_COLUMNS,
        *LEGACY_METRIC_COLUMNS,
        *EVENT_TYPES,
    }
    return sorted(
        column
        for column in episodes.columns
        if column not in fixed and not column.startswith(("objects_", "_")) and episodes[column].nunique() > 1
    )


# ---------------------------------------------------------------------------------------------------------------
# Filters

_CONDITION = re.compile(r"^\s*([A-Za-z_][\w.]*)\s*(<=|>=|!=|==|=|<|>)\s*(.*?)\s*$")


@dataclass(frozen=True)
class Condition:
    """One `--where` condition: FIELD OP VALUE with OP one of = != < <= > >=; `=`/`!=` take a comma-separated
    list (any of / none of); on `;`-list columns (axes, attributes) `=` means the list contains the value."""

    text: str
    field: str
    op: str
    values: tuple[str, ...]

    @classmethod
    def parse(cls, text: str) -> Condition:
        match = _CONDITION.match(text)
        if not match or not match.group(3):
            raise RoboLabError(
                f"--where '{text}': write FIELD=VALUE, FIELD!=VALUE or FIELD>=NUMBER (also <, <=, >), "
                'e.g. --where light_color=red,blue or --where "num_objects>=10"'
            )
        field, op, value = match.groups()
        op = "=" if op == "==" else op
        values = tuple(part.strip() for part in value.split(",")) if op in ("=", "!=") else (value,)
        return cls(text, field, op, values)

    def mask(self, episodes: pd.DataFrame) -> pd.Series:
        """Which episodes meet the condition (an error naming the field and a fix when it cannot apply)."""
        column = resolve_field(episodes, self.field, f"--where '{self.text}'")
        values = episodes[column]
        if column in LIST_COLUMNS:
            if self.op not in ("=", "!="):
                raise RoboLabError(f"--where '{self.text}': {column} is a list of names; use = or !=")
            sets = values.fillna("").str.split(";").map(set)
            hit = sets.map(lambda present: bool(present & set(self.values)))
            return hit if self.op == "=" else ~hit
        numeric = _numeric(values)
        if values.dtype == bool:
            wanted = [self._boolean(value) for value in self.values]
            if self.op not in ("=", "!="):
                raise RoboLabError(f"--where '{self.text}': {column} is true or false; use = or !=")
            hit = values.isin(wanted)
        elif numeric is not None:
            numbers = [self._number(value, column) for value in self.values]
            if self.op in ("=", "!="):
                hit = pd.Series(
                    np.isclose(numeric.to_numpy()[:, None], np.array(numbers)[None, :]).any(axis=1), index=values.index
                )
            else:
                compare = {"<": numeric.lt, "<=": numeric.le, ">": numeric.gt, ">=": numeric.ge}[self.op]
                return compare(numbers[0]).fillna(False)
        else:
            if self.op not in ("=", "!="):
                raise RoboLabError(
                    f"--where '{self.text}': {column} holds names, not numbers; use = or != "
                    f"(values: {_listing(values)})"
                )
            hit = values.astype(str).isin(self.values)
            missing = [value for value in self.values if value not in set(values.astype(str))]
            if missing:
                raise RoboLabError(
                    f"--where '{self.text}': no episode has {column}={missing[0]}; "
                    f"{did_you_mean(missing[0], values.dropna().astype(str).unique())}"
                )
        return hit if self.op == "=" else ~hit

    def _number(self, value: str, column: str) -> float:
        try:
            return float(value)
        except ValueError:
            raise RoboLabError(f"--where '{self.text}': {column} holds numbers; '{value}' is not one") from None

    def _boolean(self, value: str) -> bool:
        lowered = value.lower()
        if lowered in ("true", "1", "yes"):
            return True
        if lowered in ("false", "0", "no"):
            return False
        raise RoboLabError(f"--where '{self.text}': give true or false")


def resolve_field(episodes: pd.DataFrame, name: str, option: str) -> str:
    """The episode column that `name` (a grouping name or a column) reads, or an error with close names."""
    if name in GROUPINGS and GROUPINGS[name] in episodes.columns:
        return GROUPINGS[name]
    if name in episodes.columns and not name.startswith("_"):
        return name
    known = sorted(set(GROUPINGS) | {c for c in episodes.columns if not c.startswith("_")})
    parameters = parameter_columns(episodes)
    listed = f" Varied parameters here: {', '.join(parameters)}." if parameters else " No parameter varies here."
    raise RoboLabError(
        f"{option}: no field '{name}' in these episodes. {did_you_mean(name, known)} Groupings: "
        f"{', '.join(GROUPINGS)}.{listed} Any column of the episode lines also works "
        "(docs/results.md)."
    )


def filter_episodes(
    episodes: pd.DataFrame,
    tasks: Sequence[str] | None = None,
    policies: Sequence[str] | None = None,
    attributes: Sequence[str] | None = None,
    axes: Sequence[str] | None = None,
    where: Iterable[str | Condition] = (),
) -> pd.DataFrame:
    """The episodes that meet every filter (several values of one filter: any of them); unknown names and
    filters that leave nothing are errors that say what is there."""
    keep = pd.Series(True, index=episodes.index)
    for option, column, wanted in (("--task", "task", tasks), ("--policy", "policy", policies)):
        if wanted:
            present = set(episodes[column].astype(str))
            for name in wanted:
                if name not in present:
                    raise RoboLabError(f"{option} {name}: not in these runs. {did_you_mean(name, present)}")
            keep &= episodes[column].isin(wanted)
    for option, column, wanted in (("--attribute", "attributes", attributes), ("--axis", "axes", axes)):
        if wanted:
            lists = episodes[column].fillna("").str.split(";").map(set)
            present = set().union(*lists) - {""}
            for name in wanted:
                if name not in present:
                    raise RoboLabError(f"{option} {name}: no task of these runs has it. {did_you_mean(name, present)}")
            keep &= lists.map(lambda names, wanted=wanted: bool(names & set(wanted)))
    for condition in where:
        condition = condition if isinstance(condition, Condition) else Condition.parse(condition)
        keep &= condition.mask(episodes)
    if not keep.any():
        raise RoboLabError("the filters leave no episode: loosen --task / --policy / --attribute / --axis / --where")
    return episodes[keep]


# ---------------------------------------------------------------------------------------------------------------
# Markdown

TITLES = {"overall": "Overall", "task": "By task", "axis": "By competency axis (an episode counts under each axis "
          "of its task)", "attribute": "By attribute (an episode counts under each attribute of its task)",
          "difficulty": "By difficulty", "scene": "By scene", "variant": "By instruction variant",
          "num_objects": "By number of objects in the scene", "episode_length": "By episode length (the task's "
          "time limit, s)", "wrong_objects": "By wrong objects grasped in the episode"}  # fmt: skip


def markdown_table(table: pd.DataFrame, groups: Sequence[str]) -> str:
    """A compact Markdown table: the group columns, episodes, success % [95 % interval], score, Score(fail),
    time to success, SPARC, path length, speed and wrong grasps per episode."""
    if table.empty:
        return "_no episodes_\n"
    header = [
        *groups,
        "episodes",
        "success % [95 % CI]",
        "score",
        "score(fail)",
        "time to success s",
        "SPARC",
        "path cm",
        "speed cm/s",
        "wrong grasps/ep",
    ]
    lines = [
        "| " + " | ".join(header) + " |",
        "|" + "|".join("---" if i < len(groups) else "--:" for i in range(len(header))) + "|",
    ]
    for _, row in table.iterrows():
        cells = [_cell(row[group]) for group in groups]
        cells += [
            str(int(row["episodes"])),
            f"{row['success_%']:.1f} [{row['success_ci95_low_%']:.1f}, {row['success_ci95_high_%']:.1f}]",
            _fmt(row["score"], 2),
            _fmt(row["score_fail"], 2),
            _fmt(row["time_to_success_s"], 1),
            _fmt(row["ee_sparc"], 2),
            _fmt(row["ee_path_cm"], 0),
            _fmt(row["ee_speed_mean_cm_s"], 1),
            _fmt(row["wrong_object_grasped"], 2),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _cell(value: object) -> str:
    text = UNKNOWN if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)
    return text.replace("|", "\\|")


def _fmt(value: float, digits: int) -> str:
    return "-" if value is None or pd.isna(value) else f"{value:.{digits}f}"


# ---------------------------------------------------------------------------------------------------------------
# The command


@dataclass
class Report:
    """The tables of one `robolab analyze`: name -> (table, the grouping names in it)."""

    episodes: pd.DataFrame
    tables: dict[str, tuple[pd.DataFrame, list[str]]]
    parameters: list[str]


def build_report(episodes: pd.DataFrame, views: Sequence[str], bins: int = DEFAULT_BINS) -> Report:
    """The overall table and one table per view (grouping name or column); per varied parameter with `param_`."""
    tables: dict[str, tuple[pd.DataFrame, list[str]]] = {"overall": (breakdown(episodes), ["policy"])}
    for view in views:
        tables[view] = (breakdown(episodes, view, bins=bins), ["policy", view])
    return Report(episodes, tables, parameter_columns(episodes))


def report_markdown(report: Report, comparison=None) -> str:
    """Every table of `report` as Markdown sections (and the paired comparison, if given)."""
    parts = []
    for name, (table, groups) in report.tables.items():
        title = TITLES.get(name, f"By {name}" + (" (equal-count bins)" if f"{name}_mean" in table else ""))
        parts.append(f"## {title}\n\n{markdown_table(table, groups)}")
    if comparison is not None:
        from robolab_ms.analysis.paired import comparison_markdown

        parts.append(comparison_markdown(comparison))
    parts.append(
        "Success interval: 95 % equal-tailed Beta(k+1, n-k+1) (uniform prior). Score(fail): mean score of "
        "the failed episodes. Time to success: mean over successes. SPARC: end effector, closer to 0 is "
        "smoother.\n"
    )
    return "\n".join(parts)


def write_report(report: Report, out: Path, comparison=None, plots: bool = True) -> list[Path]:
    """Write every table as `<name>.csv` and `<name>.parquet` (`overall`, `by_<grouping>`, `paired_*`), the
    filtered episodes, `analysis.md` and, with `plots`, the figures under `plots/`; returns the files."""
    make_folder(out, "--out")
    written = []
    tables = {("overall" if name == "overall" else f"by_{name}"): table for name, (table, _) in report.tables.items()}
    tables["episodes"] = _flat(report.episodes)
    if comparison is not None:
        tables["paired_tasks"] = comparison.per_task
        tables["paired_overall"] = pd.DataFrame([comparison.overall])
    for name, table in tables.items():
        table = table.drop(columns=[c for c in table.columns if str(c).startswith("_")])
        table.to_csv(out / f"{name}.csv", index=False)
        table.to_parquet(out / f"{name}.parquet", index=False)
        written += [out / f"{name}.csv", out / f"{name}.parquet"]
    (out / "analysis.md").write_text(report_markdown(report, comparison), encoding="utf-8")
    written.append(out / "analysis.md")
    if plots:
        from robolab_ms.analysis.plots import plot_report

        written += plot_report(report, out / "plots", comparison)
    return written


def _flat(episodes: pd.DataFrame) -> pd.DataFrame:
    """Episodes with nested values (policy metadata) as text, so Parquet can store them."""
    flat = episodes.copy()
    for column in flat.columns:
        if flat[column].dtype == object and flat[column].map(lambda v: isinstance(v, (dict, list))).any():
            flat[column] = flat[column].map(lambda v: None if v is None else str(v))
        elif flat[column].dtype == object:  # missing (None, NaN) stays missing, not the text "nan"
            flat[column] = flat[column].map(
                lambda v: (
                    v if v is None or isinstance(v, str) else None if isinstance(v, float) and math.isnan(v) else str(v)
                )
            )
    return flat


# ---------------------------------------------------------------------------------------------------------------
# Helpers


def _numeric(values: pd.Series) -> pd.Series | None:
    """The values as numbers if every present value is one (booleans are not), else None."""
    if values.dtype == bool or values.dtype.name == "category":
        return None
    if pd.api.types.is_numeric_dtype(values):
        return values.astype(float)
    present = values.dropna()
    if len(present) == 0 or not present.map(lambda v: isinstance(v, (int, float)) and not isinstance(v, bool)).all():
        return None
    return pd.to_numeric(values, errors="coerce")


def _mean(frame: pd.DataFrame, column: str) -> float:
    if column not in frame:
        return float("nan")
    values = pd.to_numeric(frame[column], errors="coerce").dropna()
    return float(values.mean()) if len(values) else float("nan")


def _first(frame: pd.DataFrame, column: str) -> object:
    values = frame[column].dropna()
    return values.iloc[0] if len(values) else None


def _short(value: float) -> str:
    return f"{value:.3g}"


def _listing(values: pd.Series, limit: int = 8) -> str:
    names = sorted(values.dropna().astype(str).unique())
    return ", ".join(names[:limit]) + (", ..." if len(names) > limit else "")
