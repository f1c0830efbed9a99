"""RoboLab's sim-to-real comparison: real-robot success read from a CSV, correlated with simulated success
(Pearson and Spearman, Fisher z and bootstrap intervals), its table rows and its scatter plot."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from robolab_ms.errors import RoboLabError, did_you_mean

if TYPE_CHECKING:
    import pandas as pd


PLOT_STEM = "sim_to_real"


FEW_POLICIES = 10  # below this many policies the correlation intervals are called wide


BOOTSTRAP_RESAMPLES = 4000


PERFECT_TOLERANCE = 1e-9  # |r| this close to 1 counts as a perfect correlation (no Fisher interval)


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


CORRELATION_HEADERS = (
    "Correlation",
    "Policies",
    "Value",
    "95 % interval (Fisher z)",
    "95 % interval (bootstrap)",
    "p",
    "Note",
)


def interval_text(interval: tuple[float, float] | None) -> str:
    return "-" if interval is None else f"[{interval[0]:+.2f}, {interval[1]:+.2f}]"


def correlation_rows(comparison: SimToReal) -> list[list[str]]:
    """Rows of the correlation table: method, n, coefficient, Fisher interval, bootstrap interval, p, note."""
    rows = []
    for corr in (comparison.pearson, comparison.spearman):
        name = f"{corr.method} {'rho' if corr.method == 'Spearman' else 'r'}"
        rows.append(
            [
                name,
                str(corr.n),
                "-" if corr.r is None else f"{corr.r:+.2f}",
                interval_text(corr.fisher),
                interval_text(corr.bootstrap),
                "-" if corr.p_value is None else f"{corr.p_value:.3g}",
                corr.note,
            ]
        )
    return rows
