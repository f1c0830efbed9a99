"""A static leaderboard site over results folders, its Markdown twin, and RoboLab's sim-to-real comparison.

`robolab leaderboard RUN_DIR [RUN_DIR ...] --out SITE` writes:

- `SITE/index.html`: policies ranked by overall success (95 % Beta interval), success per competency axis and per
  difficulty, Score, Score(fail), episodes and tasks; a policies x tasks table linking to the task pages; the
  sim-to-real section with `--real-world`;
- `SITE/tasks/<Task>.html`: one page per task: its scene, difficulty, axes, attributes and instructions, and per
  policy success with its interval, score, time to success, SPARC, path length, speed and the episode videos;
- `SITE/leaderboard.md`: the same tables in Markdown (video links and plot relative to SITE);
- `SITE/videos/<run>/...`: copies of the recorded episode videos (`--videos copy`, the default);
- `SITE/sim_to_real.png`, `.svg`: with `--real-world`, real against simulated success, one point per policy.

Ranking rule: policies are ordered by overall success rate (successes / episodes over every episode of the
policy), ties by mean score, then by name; policies equal in both rate and score share a rank.

The pages are plain HTML with inline CSS, readable with scripting off and from any folder (no server, no file from
elsewhere). A short inline script makes every table sortable: click a header to sort by it (numbers as numbers,
missing values last), click again to reverse. Every name and text that comes from results or the real-world file
is HTML-escaped (and Markdown-escaped in the Markdown copy).

Videos: by default each episode's mp4 is copied into the site, so the folder works when moved or served anywhere;
`--videos link` links to the results folders instead (relative links: the site then works only next to them) and
`--videos none` leaves the links out. The site folder is emptied of an earlier leaderboard's pages before
writing; a non-empty folder that is not a leaderboard site is refused.
"""

from __future__ import annotations

import argparse
import csv
import html
import io
import math
import os
import re
import shutil
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import quote

from robolab_ms.errors import RoboLabError, did_you_mean, make_folder

if TYPE_CHECKING:
    import pandas as pd

    from robolab_ms.analysis.runs import RunSet

INDEX_HTML = "index.html"
MARKDOWN = "leaderboard.md"
TASK_DIR = "tasks"
VIDEO_DIR = "videos"
PLOT_STEM = "sim_to_real"
SITE_MARKER = ".robolab-leaderboard"  # marks a folder as a site this command wrote (and may rewrite)
VIDEO_MODES = ("copy", "link", "none")
RANKING_RULE = (
    "Ranked by overall success rate (successes / episodes over all of a policy's episodes), ties by "
    "mean score, then by name; equal rate and score share a rank."
)
INTERVAL_NOTE = (
    "Intervals: 95 % equal-tailed Bayesian interval of the success rate under a uniform prior, "
    "Beta(k + 1, n - k + 1). Score: mean graded score (1 for a success); Score(fail): mean over the "
    "failed episodes."
)
FEW_POLICIES = 10  # below this many policies the correlation intervals are called wide
BOOTSTRAP_RESAMPLES = 4000
PERFECT_TOLERANCE = 1e-9  # |r| this close to 1 counts as a perfect correlation (no Fisher interval)


# ---------------------------------------------------------------------------------------------------------------
# Numbers


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
    """One row per policy in rank order (see the module docstring): rank, policy, episodes, successes, tasks,
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


# ---------------------------------------------------------------------------------------------------------------
# Real-world success and the sim-to-real comparison


@dataclass(frozen=True)
class RealWorldResult:
    """One policy's success rate on the real robot, as read from the real-world CSV."""

    policy: str
    success: float  # 0..1
    episodes: int | None = None  # real trials, when the file gives them (then the point gets an interval)
    line: int = 0


def read_real_world(path: str | Path) -> list[RealWorldResult]:
    """The rows of a real-world results CSV: columns `policy` and `success` (a fraction 0..1, or a percentage
    written with its sign, `45%`), optionally `episodes` (real trials); other columns are ignored."""
    path = Path(path)
    shape = (
        "a CSV with a header line `policy,success` and one row per policy, success as a fraction between 0 "
        "and 1 (0.45) or a percentage with its sign (45%); an `episodes` column is optional"
    )
    if not path.is_file():
        raise RoboLabError(f"{path}: no such file; give {shape}")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        raise RoboLabError(f"{path}: not UTF-8 text (byte {error.start}); save it as UTF-8 CSV") from None
    reader = csv.reader(io.StringIO(text))
    try:
        lines = [(reader.line_num, row) for row in reader]
    except csv.Error as error:
        raise RoboLabError(f"{path}: line {reader.line_num}: not valid CSV ({error}); give {shape}") from None
    lines = [(number, row) for number, row in lines if any(cell.strip() for cell in row)]
    if not lines:
        raise RoboLabError(f"{path}: the file is empty; give {shape}")
    header_line, header_row = lines[0]
    header = [cell.strip().lower() for cell in header_row]
    for name in ("policy", "success"):
        if name not in header:
            columns = ", ".join(repr(h) for h in header)
            raise RoboLabError(
                f"{path}: line {header_line} (header): no column '{name}' (columns: {columns}). "
                f"{did_you_mean(name, header)} Give {shape}"
            )
    for name in set(header):
        if name and header.count(name) > 1:
            raise RoboLabError(f"{path}: line {header_line} (header): column '{name}' appears twice; keep one")
    if len(lines) == 1:
        raise RoboLabError(f"{path}: a header but no rows; add one row per policy ({shape})")
    results: list[RealWorldResult] = []
    seen: dict[str, int] = {}
    for row_number, (line, row) in enumerate(lines[1:], start=1):
        where = f"{path}: row {row_number} (line {line})"
        if len(row) != len(header):
            raise RoboLabError(
                f"{where}: {len(row)} fields where the header has {len(header)}; give one value per "
                "column (quote a value that contains a comma)"
            )
        cells = dict(zip(header, (cell.strip() for cell in row)))
        policy = cells["policy"]
        if not policy:
            raise RoboLabError(f"{where}, column 'policy': empty; give the policy's name as in the results")
        if policy in seen:
            raise RoboLabError(
                f"{where}, column 'policy': '{policy}' already given on line {seen[policy]}; give each policy once"
            )
        seen[policy] = line
        success = _parse_success(cells["success"], f"{where}, column 'success'")
        episodes = None
        if cells.get("episodes"):
            episodes = _parse_episodes(cells["episodes"], f"{where}, column 'episodes'")
        results.append(RealWorldResult(policy, success, episodes, line))
    return results


def _parse_success(text: str, where: str) -> float:
    percent = text.endswith("%")
    number = text[:-1].strip() if percent else text
    try:
        value = float(number)
    except ValueError:
        raise RoboLabError(
            f"{where}: '{text}' is not a number; give a fraction between 0 and 1 (0.45) or a "
            "percentage with its sign (45%)"
        ) from None
    if not math.isfinite(value):
        raise RoboLabError(f"{where}: '{text}' is not a finite number; give the measured success rate")
    top = 100.0 if percent else 1.0
    if not 0.0 <= value <= top:
        fix = (
            "give a percentage between 0% and 100%"
            if percent
            else ("give a fraction between 0 and 1, or write a percentage with its sign (45%)")
        )
        raise RoboLabError(f"{where}: {text} is outside 0..{top:g}; {fix}")
    return value / top


def _parse_episodes(text: str, where: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise RoboLabError(
            f"{where}: '{text}' is not a whole number; give the number of real trials, or leave it empty"
        ) from None
    if value < 1:
        raise RoboLabError(f"{where}: {value} trials; give at least 1, or leave it empty")
    return value


@dataclass
class Correlation:
    """A correlation between simulated and real success over the policies in both, with its 95 % intervals
    (None where they cannot be computed; `note` says why)."""

    method: str  # "Pearson" or "Spearman"
    n: int
    r: float | None = None
    p_value: float | None = None
    fisher: tuple[float, float] | None = None  # Fisher z interval
    bootstrap: tuple[float, float] | None = None  # percentile bootstrap over policies
    note: str = ""


@dataclass
class SimToReal:
    """Simulated against real success for the policies in both (table rows in leaderboard order)."""

    table: pd.DataFrame  # policy, sim, sim_low, sim_high, real, real_low, real_high (NaN without real episodes)
    pearson: Correlation
    spearman: Correlation
    only_sim: list[str] = field(default_factory=list)
    only_real: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    plot_files: list[str] = field(default_factory=list)  # relative to the site


def fisher_interval(r: float, n: int, method: str = "Pearson", level: float = 0.95) -> tuple[float, float] | None:
    """Interval of a correlation by Fisher's z transform: standard error 1/sqrt(n-3) for Pearson's r and
    sqrt(1.06/(n-3)) for Spearman's rho (Fieller, Hartley and Pearson). None when n < 4 or |r| = 1."""
    from scipy.stats import norm

    if n < 4 or not math.isfinite(r) or abs(r) >= 1.0 - PERFECT_TOLERANCE:
        return None
    se = math.sqrt((1.06 if method == "Spearman" else 1.0) / (n - 3))
    half = float(norm.ppf(0.5 + level / 2)) * se
    z = math.atanh(r)
    return math.tanh(z - half), math.tanh(z + half)


def _bootstrap_interval(x, y, method: str, seed: int = 0, level: float = 0.95) -> tuple[float, float] | None:
    """Percentile interval of the correlation over policies resampled with replacement; resamples in which either
    side is constant are skipped (None when most are)."""
    import numpy as np
    from scipy.stats import rankdata

    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(x), size=(BOOTSTRAP_RESAMPLES, len(x)))
    xs, ys = np.asarray(x, float)[picks], np.asarray(y, float)[picks]
    if method == "Spearman":
        xs, ys = rankdata(xs, axis=1), rankdata(ys, axis=1)
    xs = xs - xs.mean(axis=1, keepdims=True)
    ys = ys - ys.mean(axis=1, keepdims=True)
    norms = np.sqrt((xs**2).sum(axis=1) * (ys**2).sum(axis=1))
    usable = norms > 1e-12
    if usable.sum() < BOOTSTRAP_RESAMPLES / 2:
        return None
    values = np.clip((xs * ys).sum(axis=1)[usable] / norms[usable], -1.0, 1.0)
    tail = 100 * (1 - level) / 2
    return float(np.percentile(values, tail)), float(np.percentile(values, 100 - tail))


def correlate(sim: Sequence[float], real: Sequence[float], method: str) -> Correlation:
    """Pearson's r or Spearman's rho of two equally long sequences, with Fisher and bootstrap intervals."""
    import numpy as np
    from scipy.stats import pearsonr, spearmanr

    n = len(sim)
    if n < 3:
        return Correlation(
            method,
            n,
            note=f"not computed: {n} polic{'y' if n == 1 else 'ies'} in both the "
            "results and the real-world file; a correlation needs at least 3 (with 2 it is always "
            "+1 or -1)",
        )
    if np.ptp(np.asarray(sim, float)) == 0 or np.ptp(np.asarray(real, float)) == 0:
        side = "simulated" if np.ptp(np.asarray(sim, float)) == 0 else "real"
        return Correlation(method, n, note=f"not defined: every {side} success rate is the same")
    r, p = (pearsonr if method == "Pearson" else spearmanr)(sim, real)
    r, p = float(r), float(p)
    if abs(r) >= 1.0 - PERFECT_TOLERANCE:
        r = math.copysign(1.0, r)  # perfect agreement up to rounding
    notes = []
    fisher = fisher_interval(r, n, method)
    if fisher is None:
        notes.append(
            "Fisher interval needs at least 4 policies"
            if n < 4
            else f"Fisher interval not defined at {'rho' if method == 'Spearman' else 'r'} = {r:+.0f}"
        )
    bootstrap = _bootstrap_interval(sim, real, method)
    if bootstrap is None:
        notes.append("bootstrap interval not defined: most resamples have a constant side")
    return Correlation(method, n, r, p, fisher, bootstrap, "; ".join(notes))


def compare_sim_to_real(ranking: pd.DataFrame, real: Sequence[RealWorldResult]) -> SimToReal:
    """Correlate the leaderboard's overall success with the real-world success of the policies in both."""
    import pandas as pd

    from robolab_ms.analysis.tables import success_interval

    real_by_policy = {row.policy: row for row in real}
    sim_policies = list(ranking["policy"]) if len(ranking) else []
    rows = []
    for row in ranking.itertuples(index=False):
        if row.policy not in real_by_policy:
            continue
        measured = real_by_policy[row.policy]
        low = high = math.nan
        if measured.episodes:
            low, high = success_interval(round(measured.success * measured.episodes), measured.episodes)
        rows.append(
            {
                "policy": row.policy,
                "sim": row.success,
                "sim_low": row.success_low,
                "sim_high": row.success_high,
                "real": measured.success,
                "real_low": low,
                "real_high": high,
                "real_episodes": measured.episodes,
            }
        )
    table = pd.DataFrame(
        rows, columns=["policy", "sim", "sim_low", "sim_high", "real", "real_low", "real_high", "real_episodes"]
    )
    comparison = SimToReal(
        table,
        correlate(list(table["sim"]), list(table["real"]), "Pearson"),
        correlate(list(table["sim"]), list(table["real"]), "Spearman"),
        only_sim=[p for p in sim_policies if p not in real_by_policy],
        only_real=[row.policy for row in real if row.policy not in set(sim_policies)],
    )
    n = len(table)
    if 3 <= n < FEW_POLICIES:
        comparison.notes.append(
            f"Only {n} policies are in both: the intervals are wide, read the correlation as a "
            "rough check rather than a measurement."
        )
    if comparison.only_real:
        comparison.notes.append(
            "In the real-world file but without simulated episodes (left out): " + ", ".join(comparison.only_real) + "."
        )
    if comparison.only_sim:
        comparison.notes.append("Without a real-world result (left out): " + ", ".join(comparison.only_sim) + ".")
    return comparison


def plot_sim_to_real(comparison: SimToReal, out_dir: Path) -> list[str]:
    """Scatter real against simulated success (with intervals where known) and the y = x line, as
    `sim_to_real.png` and `.svg` in `out_dir`; returns the file names. Nothing is drawn without points."""
    import numpy as np
    from matplotlib.figure import Figure

    table = comparison.table
    if table.empty:
        return []
    figure = Figure(figsize=(5.6, 5.2), layout="constrained")
    axes = figure.add_subplot()
    axes.plot([0, 100], [0, 100], linestyle="--", color="#999999", linewidth=1, label="sim = real")
    sim, real = 100 * table["sim"].to_numpy(float), 100 * table["real"].to_numpy(float)
    x_err = np.vstack([sim - 100 * table["sim_low"].to_numpy(float), 100 * table["sim_high"].to_numpy(float) - sim])
    y_err = np.vstack([real - 100 * table["real_low"].to_numpy(float), 100 * table["real_high"].to_numpy(float) - real])
    # a rate of 0 or 1 lies outside its equal-tailed Beta interval: no bar on that side (as in analyze's plots)
    x_err, y_err = x_err.clip(min=0), np.nan_to_num(y_err, nan=0.0).clip(min=0)
    axes.errorbar(
        sim,
        real,
        xerr=x_err,
        yerr=y_err,
        fmt="o",
        color="#1f5fa8",
        ecolor="#8fb0d8",
        elinewidth=1.2,
        capsize=3,
        label="policy (95 % intervals)",
    )
    for name, x, y in zip(table["policy"], sim, real):
        axes.annotate(name, (x, y), xytext=(5, 5), textcoords="offset points", fontsize=8, parse_math=False)
    axes.set_xlim(-3, 103)
    axes.set_ylim(-3, 103)
    axes.set_aspect("equal")
    axes.set_xlabel("simulated success (%)")
    axes.set_ylabel("real-world success (%)")
    axes.grid(alpha=0.3)
    axes.legend(loc="lower right", fontsize=8)
    title = "Sim vs real success"
    pearson, spearman = comparison.pearson, comparison.spearman
    if pearson.r is not None and spearman.r is not None:
        title += f"\nPearson r = {pearson.r:.2f}, Spearman rho = {spearman.r:.2f} (n = {pearson.n})"
    else:
        title += f"\n(n = {pearson.n}: too few policies for a correlation)"
    axes.set_title(title, fontsize=10)
    files = []
    for suffix, options in ((".png", {"dpi": 150}), (".svg", {})):
        name = PLOT_STEM + suffix
        figure.savefig(Path(out_dir) / name, **options)
        files.append(name)
    return files


# ---------------------------------------------------------------------------------------------------------------
# Episode videos


@dataclass(frozen=True)
class VideoLink:
    """One episode's video as linked from the site: `href` is relative to the site folder."""

    label: str
    href: str
    success: bool


def collect_videos(runs: RunSet, site: Path, mode: str) -> dict[tuple[str, str], list[VideoLink]]:
    """The video links per (policy, task): files copied into `site/videos/<run>/` (`copy`), relative links to the
    results folders (`link`) or none. Videos whose file is missing or that point outside their results folder are
    skipped with a warning."""
    from robolab_ms.analysis.runs import _run_labels

    links: dict[tuple[str, str], list[VideoLink]] = {}
    if mode == "none" or "video" not in runs.episodes:
        return links
    folder_of = dict(zip(_run_labels(runs.folders), runs.folders))
    run_dirs = _unique_slugs(list(folder_of))
    variants = runs.episodes["instruction_variant"].nunique() > 1
    missing = []
    for row in runs.episodes.sort_values(["policy", "task", "instruction_variant", "seed"]).itertuples(index=False):
        if not isinstance(row.video, str) or not row.video:
            continue
        folder = folder_of[row.run].resolve()
        source = (folder / row.video).resolve()
        if not source.is_relative_to(folder) or not source.is_file():
            missing.append(f"{row.run}/{row.video}")
            continue
        if mode == "copy":
            inside = source.relative_to(folder)  # usually videos/<Task>/<file>.mp4: its videos/ is not repeated
            inside = inside.relative_to(VIDEO_DIR) if inside.parts[0] == VIDEO_DIR and len(inside.parts) > 1 else inside
            target = site / VIDEO_DIR / run_dirs[row.run] / inside
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
            href = target.relative_to(site).as_posix()
        else:
            href = Path(os.path.relpath(source, site.resolve())).as_posix()
        label = f"seed {row.seed}" + (f" {row.instruction_variant}" if variants else "")
        links.setdefault((str(row.policy), str(row.task)), []).append(VideoLink(label, href, bool(row.success)))
    if missing:
        warnings.warn(
            f"{len(missing)} episode video(s) missing or outside their results folder, not linked: "
            + ", ".join(missing[:5])
            + (", ..." if len(missing) > 5 else ""),
            stacklevel=2,
        )
    return links


def _slug(name: str) -> str:
    """A file-name-safe version of a name (letters, digits, `-`, `_`, `.`), never empty or hidden."""
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "item"
    return slug[:80]


def _unique_slugs(names: Sequence[str]) -> dict[str, str]:
    """A distinct slug per name, in order (a repeated slug gets -2, -3 ...)."""
    slugs: dict[str, str] = {}
    taken: set[str] = set()
    for name in names:
        base = slug = _slug(name)
        counter = 1
        while slug.lower() in taken:
            counter += 1
            slug = f"{base}-{counter}"
        taken.add(slug.lower())
        slugs[name] = slug
    return slugs


# ---------------------------------------------------------------------------------------------------------------
# The site


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
    from robolab_ms.analysis.runs import DIFFICULTY_ORDER

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
    slugs = _unique_slugs(list(tasks["task"]))
    board = Leaderboard(
        ranking=ranking,
        axes=group_rates(episodes, "axis", ("visual", "relational", "procedural")),
        difficulties=group_rates(episodes, "difficulty", DIFFICULTY_ORDER),
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


def write_site(
    runs: RunSet,
    out: str | Path,
    real_world: Sequence[RealWorldResult] | None = None,
    videos: str = "copy",
    title: str = "RoboLab leaderboard",
) -> Leaderboard:
    """Write the leaderboard site and its Markdown copy into `out` (layout in the module docstring)."""
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


# --- HTML pieces: every value from the results passes through _esc -------------------------------------------

STYLE = """
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; color: #1d232b;
       margin: 0 auto; padding: 1.2em 1.6em 3em; max-width: 1320px; background: #fbfbfc; }
h1 { font-size: 1.6em; margin: 0.2em 0 0.1em; }
h2 { font-size: 1.2em; margin: 1.8em 0 0.5em; border-bottom: 1px solid #dde1e6; padding-bottom: 0.2em; }
p.lead, p.note, p.rule { color: #4a5563; margin: 0.3em 0; }
p.note { background: #fff6e0; border-left: 3px solid #e0a800; padding: 0.3em 0.6em; }
table { border-collapse: collapse; margin: 0.6em 0; background: #fff; box-shadow: 0 1px 2px rgba(0,0,0,.06); }
th, td { padding: 0.35em 0.6em; border-bottom: 1px solid #e6e9ee; text-align: right; vertical-align: top;
         white-space: nowrap; }
td.text, td.name { white-space: normal; }
div.scroll { overflow-x: auto; }
th { background: #eef1f5; font-weight: 600; white-space: nowrap; user-select: none; }
th.text, td.text { text-align: left; }
table.sortable th { cursor: pointer; }
table.sortable th:hover { background: #e1e6ed; }
th[aria-sort="ascending"]::after { content: " \\25B2"; font-size: 0.7em; }
th[aria-sort="descending"]::after { content: " \\25BC"; font-size: 0.7em; }
tbody tr:nth-child(even) { background: #f7f8fa; }
td.name { font-weight: 600; text-align: left; max-width: 22em; overflow-wrap: break-word; }
small, .ci { color: #6b7480; font-size: 0.8em; white-space: nowrap; }
td .ci { display: block; line-height: 1.2; }
.bar { display: inline-block; width: 4.5em; height: 0.5em; background: #e3e7ec; border-radius: 2px;
       margin-right: 0.4em; vertical-align: middle; }
.bar > span { display: block; height: 100%; background: #2f7ed8; border-radius: 2px; }
.missing { color: #aab1ba; }
a { color: #1f5fa8; }
.videos a { margin-right: 0.5em; white-space: nowrap; }
.videos a.ok::before { content: "\\2713 "; color: #2c9a4a; }
.videos a.fail::before { content: "\\2717 "; color: #c0392b; }
dl.facts { display: grid; grid-template-columns: max-content auto; gap: 0.2em 1em; margin: 0.6em 0; }
dl.facts dt { font-weight: 600; color: #4a5563; }
dl.facts dd { margin: 0; }
img.plot { max-width: 560px; width: 100%; border: 1px solid #dde1e6; background: #fff; }
footer { margin-top: 2.5em; color: #6b7480; font-size: 0.85em; }
"""

# Sorts a table by the clicked header: data-sort values (or the cell text), numbers as numbers, empty values last;
# a second click on the same header reverses the order.
SORT_SCRIPT = """
(function () {
  function sortValue(cell) {
    var text = cell.hasAttribute('data-sort') ? cell.getAttribute('data-sort') : cell.textContent.trim();
    var number = Number(text);
    if (text === '') return {empty: true};
    return isNaN(number) ? {text: text.toLowerCase()} : {number: number};
  }
  function compare(a, b) {
    if (a.empty || b.empty) return (a.empty ? 1 : 0) - (b.empty ? 1 : 0);
    if ('number' in a && 'number' in b) return a.number - b.number;
    var x = 'number' in a ? String(a.number) : a.text, y = 'number' in b ? String(b.number) : b.text;
    return x < y ? -1 : x > y ? 1 : 0;
  }
  function sortBy(table, column, header) {
    var descending = header.getAttribute('aria-sort') === 'ascending';
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th) { th.setAttribute('aria-sort', 'none'); });
    header.setAttribute('aria-sort', descending ? 'descending' : 'ascending');
    var body = table.tBodies[0];
    var rows = Array.prototype.slice.call(body.rows).map(function (row) {
      return {row: row, value: sortValue(row.cells[column])};
    });
    rows.sort(function (a, b) {
      if (a.value.empty || b.value.empty) return compare(a.value, b.value);
      return descending ? compare(b.value, a.value) : compare(a.value, b.value);
    });
    rows.forEach(function (item) { body.appendChild(item.row); });
  }
  Array.prototype.forEach.call(document.querySelectorAll('table.sortable'), function (table) {
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (header, column) {
      header.tabIndex = 0;
      header.title = 'sort by this column (click again to reverse)';
      header.addEventListener('click', function () { sortBy(table, column, header); });
      header.addEventListener('keydown', function (event) {
        if (event.key === 'Enter' || event.key === ' ') { event.preventDefault(); sortBy(table, column, header); }
      });
    });
  });
})();
"""


TEXT_CLASS = ' class="text"'  # a left-aligned (text) cell


def _esc(value: object) -> str:
    return html.escape(str(value), quote=True)


def _href(path: str) -> str:
    """A relative link, percent-encoded and escaped for an attribute."""
    return _esc(quote(path, safe="/._-~"))


def _interval_percent(low: float, high: float) -> str:
    """An interval of a rate in whole percent, rounded outwards (so it never looks narrower than it is)."""
    return f"[{math.floor(100 * low + 1e-9):.0f}, {math.ceil(100 * high - 1e-9):.0f}]"


def _number(value: float, digits: int = 2) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def _sort_key(value: float | None) -> str:
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else repr(float(value))


def _num_cell(value: float, digits: int = 2, extra: str = "") -> str:
    shown = _number(value, digits)
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
        f'<span class="ci">{_interval_percent(low, high)}</span></td>'
    )


def _page(title: str, body: str) -> str:
    return (
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f'<meta name="viewport" content="width=device-width, initial-scale=1">\n<title>{_esc(title)}</title>\n'
        f"<style>{STYLE}</style>\n</head>\n<body>\n{body}\n<script>{SORT_SCRIPT}</script>\n</body>\n"
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
            f'<td class="text">{_esc(_text(task.difficulty))}</td>',
            f'<td class="text">{_esc(_text(task.axes).replace(";", ", "))}</td>',
        ]
        cells += [_rate_cell(board.task_rates.get((task.task, policy))) for policy in policies]
        rows.append(f"<tr>{''.join(cells)}</tr>")
    return (
        '<h2>Tasks</h2>\n<p class="lead">Success % per task and policy; a task\'s page has its scores, times, '
        "trajectory metrics and videos.</p>\n" + _table("tasks", _head_row(headers), rows)
    )


def _text(value: object) -> str:
    """A table value as text ('' for a missing one)."""
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)


def _interval_text(interval: tuple[float, float] | None) -> str:
    return "-" if interval is None else f"[{interval[0]:+.2f}, {interval[1]:+.2f}]"


def _correlation_rows(comparison: SimToReal) -> list[list[str]]:
    """Rows of the correlation table: method, n, coefficient, Fisher interval, bootstrap interval, p, note."""
    rows = []
    for corr in (comparison.pearson, comparison.spearman):
        name = f"{corr.method} {'rho' if corr.method == 'Spearman' else 'r'}"
        rows.append(
            [
                name,
                str(corr.n),
                "-" if corr.r is None else f"{corr.r:+.2f}",
                _interval_text(corr.fisher),
                _interval_text(corr.bootstrap),
                "-" if corr.p_value is None else f"{corr.p_value:.3g}",
                corr.note,
            ]
        )
    return rows


CORRELATION_HEADERS = (
    "Correlation",
    "Policies",
    "Value",
    "95 % interval (Fisher z)",
    "95 % interval (bootstrap)",
    "p",
    "Note",
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
        for row in _correlation_rows(comparison)
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
            f"{_interval_percent(row.sim_low, row.sim_high)}</span></td>{real_cell}</tr>"
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
        ("Scene", _text(info["scene"])),
        ("Difficulty", _text(info["difficulty"])),
        ("Axes", _text(info["axes"]).replace(";", ", ")),
        ("Attributes", _text(info["attributes"]).replace(";", ", ")),
    ]
    facts += [(f"Instruction ({variant})", _text(text)) for variant, text in instructions.itertuples(index=False)]
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


# --- Markdown ----------------------------------------------------------------------------------------------------


def _md(value: object) -> str:
    """Text safe in a Markdown table cell: HTML-escaped, Markdown punctuation and pipes backslash-escaped."""
    text = html.escape(" ".join(str(value).split()), quote=False)
    return re.sub(r"([\\`*_\[\]|~])", r"\\\1", text)


def _md_rate(rate: Rate | None) -> str:
    if rate is None or rate.episodes == 0:
        return "-"
    low, high = rate.interval
    return f"{100 * rate.value:.1f} {_interval_percent(low, high)}"


def _md_table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
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
        cells = [str(row.rank), _md(row.policy), _md_rate(Rate(row.successes, row.episodes))]
        cells += [_md_rate(rates.get(row.policy)) for rates in board.axes.values()]
        cells += [_md_rate(rates.get(row.policy)) for rates in board.difficulties.values()]
        cells += [_number(row.score), _number(row.score_fail), str(row.episodes), str(row.tasks)]
        rows.append(cells)
    parts += ["\n## Policies\n\n", _md_table(headers, rows)]
    policies = list(board.ranking["policy"])
    rows = [
        [_md(t.task), _md(_text(t.difficulty)), _md(_text(t.axes).replace(";", ", "))]
        + [_md_rate(board.task_rates.get((t.task, p))) for p in policies]
        for t in board.tasks.itertuples()
    ]
    task_headers = ["Task", "Difficulty", "Axes", *(_md(policy) for policy in policies)]
    parts += ["\n## Tasks (success %)\n\n", _md_table(task_headers, rows)]
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
                    _md_rate(Rate(row.successes, row.episodes)),
                    _number(row.score),
                    _number(row.score_fail),
                    _number(row.time_to_success_s, 1),
                    _number(row.ee_sparc),
                    _number(row.ee_path_cm, 1),
                    _number(row.ee_speed_mean_cm_s, 1),
                    str(row.episodes),
                    videos,
                ]
            )
        parts += [f"\n### {_md(task)}\n\n", _md_table(headers, rows)]
    if board.sim_to_real is not None:
        comparison = board.sim_to_real
        parts.append("\n## Sim to real\n\n")
        parts += [f"> {_md(note)}\n\n" for note in comparison.notes]
        parts.append(_md_table(CORRELATION_HEADERS, [[_md(v) for v in row] for row in _correlation_rows(comparison)]))
        rows = [
            [_md(r.policy), f"{100 * r.sim:.1f} {_interval_percent(r.sim_low, r.sim_high)}", f"{100 * r.real:.1f}"]
            for r in comparison.table.itertuples(index=False)
        ]
        parts += ["\n", _md_table(["Policy", "Sim success %", "Real success %"], rows)]
        if comparison.plot_files:
            parts.append(f"\n![real against simulated success]({PLOT_STEM}.png)\n")
    return "".join(parts)


# --- command line ----------------------------------------------------------------------------------------------


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
        [str(r.rank), r.policy, _md_rate(Rate(r.successes, r.episodes)), _number(r.score), str(r.episodes)]
        for r in board.ranking.itertuples(index=False)
    ]
    print(_md_table(headers, rows), end="")
    if board.sim_to_real is not None:
        for corr in (board.sim_to_real.pearson, board.sim_to_real.spearman):
            value = (
                "-"
                if corr.r is None
                else (
                    f"{corr.r:+.2f} (Fisher {_interval_text(corr.fisher)}, bootstrap {_interval_text(corr.bootstrap)})"
                )
            )
            note = f"; {corr.note}" if corr.note else ""
            print(f"sim to real, {corr.method} over {corr.n} policies: {value}{note}")
    print(f"wrote {site / INDEX_HTML}, {len(board.task_pages)} task pages and {site / MARKDOWN}")
    return 0
