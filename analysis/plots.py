"""Figures of `robolab analyze --out DIR` (matplotlib, drawn off-screen), each as PNG and SVG under DIR/plots/:

- `success_by_axis`, `success_by_difficulty`: success % with its 95 % Beta interval per policy;
- `score_vs_complexity`: each task's mean score against its difficulty score (RoboLab's rating: subtasks plus
  skill weight), per policy, with the mean per difficulty score as a line;
- `success_heatmap`: tasks (rows) x policies (columns), success % in each cell;
- `success_by_parameter` (`_2`, ... when there are many): success % against each varied parameter, numbers in
  equal-count bins (at the mean value of the bin), names per category, with 95 % intervals; a parameter drawn in
  some episodes only (an object of one task's scene) from those episodes, its panel says how many.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from robolab_ms.analysis.report import Report, breakdown

PANELS_PER_FIGURE = 12
PNG_DPI = 100


def _pyplot():
    """matplotlib's pyplot on the off-screen Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update(
        {
            "font.size": 9,
            "axes.titlesize": 10,
            "axes.spines.top": False,
            "axes.spines.right": False,
            "svg.fonttype": "none",
            "text.parse_math": False,
        }
    )
    return plt


def policy_colours(policies: Sequence[str]) -> dict[str, tuple]:
    """One colour per policy (matplotlib's tab10 in sorted order), the same in every figure."""
    plt = _pyplot()
    palette = plt.get_cmap("tab10").colors
    return {policy: palette[i % len(palette)] for i, policy in enumerate(sorted(policies))}


def save(figure, stem: Path) -> list[Path]:
    """Write `figure` as stem.png and stem.svg, close it, return both paths."""
    plt = _pyplot()
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_suffix(".png"), stem.with_suffix(".svg")]
    figure.savefig(paths[0], dpi=PNG_DPI, bbox_inches="tight")
    figure.savefig(paths[1], bbox_inches="tight")
    plt.close(figure)
    return paths


def _interval_errors(table: pd.DataFrame) -> np.ndarray:
    """Error bar lengths (below, above) of success % from its interval columns."""
    return np.vstack(
        [table["success_%"] - table["success_ci95_low_%"], table["success_ci95_high_%"] - table["success_%"]]
    ).clip(min=0)


def _dodge(count: int, width: float = 0.7) -> np.ndarray:
    """Horizontal offsets that set `count` policies side by side within one category."""
    if count == 1:
        return np.zeros(1)
    return np.linspace(-width / 2, width / 2, count)


def success_by_group(table: pd.DataFrame, group: str, stem: Path, title: str) -> list[Path]:
    """Success % with 95 % intervals per category of `group` (x) and policy (colour)."""
    plt = _pyplot()
    categories = [c for c in pd.unique(table[group]) if c in set(table[group])]
    if table[group].dtype.name == "category":
        categories = [c for c in table[group].cat.categories if c in set(table[group])]
    policies = sorted(table["policy"].unique())
    colours = policy_colours(policies)
    offsets = _dodge(len(policies), 0.6)
    figure, axes = plt.subplots(figsize=(max(4.5, 1.1 * len(categories) + 1.5), 3.4))
    for offset, policy in zip(offsets, policies):
        rows = table[table["policy"] == policy].set_index(group).reindex(categories).dropna(subset=["success_%"])
        x = np.array([categories.index(c) for c in rows.index]) + offset
        axes.errorbar(
            x,
            rows["success_%"],
            yerr=_interval_errors(rows),
            fmt="o",
            capsize=3,
            markersize=5,
            color=colours[policy],
            label=policy,
        )
        for xi, (_, row) in zip(x, rows.iterrows()):
            axes.annotate(
                f"n={int(row['episodes'])}",
                (xi, row["success_ci95_low_%"]),
                textcoords="offset points",
                xytext=(0, -10),
                ha="center",
                fontsize=6.5,
                color="0.4",
            )
    axes.set_xticks(
        range(len(categories)),
        [str(c) for c in categories],
        rotation=30 if max(len(str(c)) for c in categories) > 10 else 0,
        ha="right" if max(len(str(c)) for c in categories) > 10 else "center",
    )
    axes.set_xlim(-0.6, len(categories) - 0.4)
    axes.set_ylim(-8, 105)
    axes.set_ylabel("success % (95 % interval)")
    axes.set_title(title)
    axes.grid(axis="y", alpha=0.3)
    axes.legend(title="policy", loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return save(figure, stem)


def score_vs_complexity(task_table: pd.DataFrame, stem: Path) -> list[Path]:
    """Each task's mean score against its difficulty score, per policy; lines join the per-score means."""
    plt = _pyplot()
    table = task_table.dropna(subset=["difficulty_score"])
    policies = sorted(table["policy"].unique())
    colours = policy_colours(policies)
    offsets = _dodge(len(policies), 0.3)
    figure, axes = plt.subplots(figsize=(6.0, 3.6))
    rng = np.random.default_rng(0)  # spread tasks of one rating a little so they do not hide each other
    for offset, policy in zip(offsets, policies):
        rows = table[table["policy"] == policy]
        x = rows["difficulty_score"].astype(float) + offset + rng.uniform(-0.05, 0.05, len(rows))
        axes.scatter(x, rows["score"], s=18, alpha=0.6, color=colours[policy], edgecolor="none")
        means = rows.groupby("difficulty_score")["score"].mean()
        axes.plot(
            means.index.astype(float) + offset,
            means.values,
            "-",
            marker="D",
            markersize=5,
            color=colours[policy],
            label=f"{policy} (mean per rating)",
        )
    scores = sorted(table["difficulty_score"].astype(int).unique())
    axes.set_xticks(scores)
    axes.set_xlabel("task complexity: RoboLab difficulty score (subtasks + skill weight)")
    axes.set_ylabel("mean Score per task")
    axes.set_ylim(-0.05, 1.05)
    axes.set_title("Score against task complexity (one dot per task and policy)")
    axes.grid(alpha=0.3)
    axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return save(figure, stem)


def success_heatmap(task_table: pd.DataFrame, stem: Path) -> list[Path]:
    """Tasks (rows, best-solved first) x policies (columns), success % in each cell."""
    plt = _pyplot()
    grid = task_table.pivot_table(index="task", columns="policy", values="success_%", aggfunc="first")
    grid = grid.loc[grid.mean(axis=1).sort_values(ascending=False, kind="stable").index]
    rows, columns = grid.shape
    figure, axes = plt.subplots(figsize=(2.2 + 0.9 * columns, 1.0 + 0.26 * rows))
    image = axes.imshow(grid.to_numpy(), cmap="RdYlGn", vmin=0, vmax=100, aspect="auto")
    for (i, j), value in np.ndenumerate(grid.to_numpy()):
        if not math.isnan(value):
            axes.text(
                j,
                i,
                f"{value:.0f}",
                ha="center",
                va="center",
                fontsize=7,
                color="white" if value < 20 or value > 85 else "black",
            )
    axes.set_xticks(
        range(columns), grid.columns, rotation=30 if columns > 3 else 0, ha="right" if columns > 3 else "center"
    )
    axes.set_yticks(range(rows), grid.index, fontsize=7.5)
    axes.tick_params(length=0)
    for side in axes.spines.values():
        side.set_visible(False)
    bar = figure.colorbar(image, ax=axes, fraction=0.05 if rows > 6 else 0.12, pad=0.03)
    bar.set_label("success %")
    axes.set_title("Success % per task and policy")
    return save(figure, stem)


def success_by_parameters(episodes: pd.DataFrame, parameters: Sequence[str], stem: Path, bins: int = 5) -> list[Path]:
    """Success % against each varied parameter, one panel each, 12 panels per figure."""
    plt = _pyplot()
    policies = sorted(episodes["policy"].unique())
    colours = policy_colours(policies)
    written = []
    for page, start in enumerate(range(0, len(parameters), PANELS_PER_FIGURE)):
        chosen = parameters[start : start + PANELS_PER_FIGURE]
        columns = min(3, len(chosen))
        rows = math.ceil(len(chosen) / columns)
        figure, grid = plt.subplots(rows, columns, figsize=(3.6 * columns, 2.8 * rows), squeeze=False)
        for axes, parameter in zip(grid.flat, chosen):
            drawn = episodes[episodes[parameter].notna()]  # a parameter of one task's object: its episodes only
            _parameter_panel(axes, breakdown(drawn, parameter, bins=bins), parameter, policies, colours)
            if len(drawn) < len(episodes):
                axes.set_title(f"{axes.get_title()}\n{len(drawn)} of {len(episodes)} episodes", fontsize=9)
        for axes in list(grid.flat)[len(chosen) :]:
            axes.set_visible(False)
        handles, labels = grid.flat[0].get_legend_handles_labels()
        figure.legend(handles, labels, title="policy", loc="upper left", bbox_to_anchor=(1.0, 0.98), frameon=False)
        figure.suptitle("Success % against each varied parameter (95 % intervals)", y=1.0)
        figure.tight_layout()
        written += save(figure, stem.with_name(stem.name + ("" if page == 0 else f"_{page + 1}")))
    return written


def _parameter_panel(axes, table: pd.DataFrame, parameter: str, policies: Sequence[str], colours: dict) -> None:
    binned = f"{parameter}_mean" in table
    offsets = _dodge(len(policies), 0.5)
    if table[parameter].dtype.name == "category":
        categories = [c for c in table[parameter].cat.categories if c in set(table[parameter])]
    else:
        present = list(table[parameter].dropna().unique())
        numbers = all(isinstance(v, (int, float, np.number)) and not isinstance(v, (bool, np.bool_)) for v in present)
        categories = sorted(present) if numbers else sorted(present, key=str)
    span = 1.0
    if binned:
        centres = table[f"{parameter}_mean"].astype(float)
        span = float(centres.max() - centres.min()) or 1.0
    for offset, policy in zip(offsets, policies):
        rows = table[table["policy"] == policy]
        if binned:
            x = rows[f"{parameter}_mean"].astype(float) + offset * span * 0.04
            axes.errorbar(
                x,
                rows["success_%"],
                yerr=_interval_errors(rows),
                fmt="-o",
                capsize=2,
                markersize=3.5,
                linewidth=1,
                color=colours[policy],
                label=policy,
            )
        else:
            x = np.array([categories.index(c) for c in rows[parameter]]) + offset * 0.5
            axes.errorbar(
                x,
                rows["success_%"],
                yerr=_interval_errors(rows),
                fmt="o",
                capsize=2,
                markersize=3.5,
                color=colours[policy],
                label=policy,
            )
    if not binned:
        long = max(len(str(c)) for c in categories) > 6 or len(categories) > 5
        axes.set_xticks(
            range(len(categories)),
            [str(c) for c in categories],
            rotation=35 if long else 0,
            ha="right" if long else "center",
            fontsize=7.5,
        )
        axes.set_xlim(-0.6, len(categories) - 0.4)
    axes.set_title(parameter + (" (binned)" if binned else ""), fontsize=9)
    axes.set_ylim(-5, 105)
    axes.set_ylabel("success %", fontsize=8)
    axes.grid(alpha=0.3)


def plot_report(report: Report, folder: Path, comparison=None) -> list[Path]:
    """Every figure of the module docstring that the report's episodes allow; returns the files written."""
    written = []
    tables = report.tables
    for name, title in (("axis", "Success by competency axis"), ("difficulty", "Success by difficulty")):
        table = tables[name][0] if name in tables else breakdown(report.episodes, name)
        if not table.empty:
            written += success_by_group(table, name, folder / f"success_by_{name}", title)
    tasks = tables["task"][0] if "task" in tables else breakdown(report.episodes, "task")
    if tasks["difficulty_score"].notna().any():
        written += score_vs_complexity(tasks, folder / "score_vs_complexity")
    written += success_heatmap(tasks, folder / "success_heatmap")
    if report.parameters:
        written += success_by_parameters(report.episodes, report.parameters, folder / "success_by_parameter")
    if comparison is not None:
        written += paired_differences(comparison, folder / "paired_difference")
    return written


def paired_differences(comparison, stem: Path) -> list[Path]:
    """Per-task difference A - B in success % with its interval, and the overall one (bootstrap over tasks)."""
    plt = _pyplot()
    table = comparison.per_task.sort_values("difference_%", kind="stable")
    overall = comparison.overall
    labels = [*table["task"], "overall (mean over tasks)"]
    values = np.array([*table["difference_%"], overall["difference_%"]])
    low = np.array([*table["ci_low_%"], overall["ci_low_%"]])
    high = np.array([*table["ci_high_%"], overall["ci_high_%"]])
    figure, axes = plt.subplots(figsize=(6.4, 1.0 + 0.28 * len(labels)))
    y = np.arange(len(labels))
    colours = ["tab:red" if s else "0.35" for s in table["significant"]] + ["black"]
    for yi, value, lo, hi, colour in zip(y, values, low, high, colours):
        axes.errorbar(
            value,
            yi,
            xerr=[[value - lo], [hi - value]],
            fmt="D" if yi == len(labels) - 1 else "o",
            color=colour,
            capsize=3,
            markersize=4,
        )
    axes.axvline(0, color="0.6", linewidth=0.8)
    axes.axhline(len(labels) - 1.5, color="0.8", linewidth=0.8)
    axes.set_ylim(-0.7, len(labels) - 0.3)
    axes.set_yticks(y, labels, fontsize=7.5)
    axes.set_xlim(-105, 105)
    axes.set_xlabel(f"success difference {comparison.a} - {comparison.b} (points, 95 % interval)")
    axes.set_title(f"Paired comparison {comparison.a} vs {comparison.b} (red: McNemar p < {1 - comparison.level:g})")
    axes.grid(axis="x", alpha=0.3)
    return save(figure, stem)
