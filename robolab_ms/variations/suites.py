"""Named suites: RoboLab's robustness experiments as fixed conditions, one results folder per condition.

Every suite starts with `default` (nothing varies), the column the others are compared with. A condition is a
`--vary` text; `robolab suites` lists them and `robolab eval --suite NAME[:COND/COND...]` runs them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robolab_ms.errors import UnknownNameError
from robolab_ms.variations.base import VariationError

BASELINE = "default"


@dataclass(frozen=True)
class Suite:
    """A suite: its name, what it measures, and its conditions (name -> `--vary` text; '' = nothing varies)."""

    name: str
    description: str
    conditions: dict[str, str]


def suites() -> dict[str, Suite]:
    """Every suite by name (backgrounds and table materials as assets/backgrounds.yaml lists them)."""
    from robolab_ms.scene.backgrounds import load_looks

    looks = load_looks()
    made = [
        Suite(
            "lighting",
            "RoboLab's lighting conditions: very dim, very bright, a hard directional key light (from "
            "the front, behind, left, right or above, drawn per episode), strong red, green and blue light, and "
            "the environment (dome) light low and high",
            {
                name: f"lighting={name}"
                for name in ("dim", "bright", "directional", "red", "green", "blue", "dome_low", "dome_high")
            },
        ),
        Suite(
            "background",
            "each HDR environment map, seen behind the table and lighting the scene",
            {name: f"background={name}" for name in looks.backgrounds},
        ),
        Suite(
            "table",
            "each table material (light_wood = RoboLab's oak, wood_planks = its walnut planks, bamboo, black_matte)",
            {name: f"table={name}" for name in looks.table_materials},
        ),
        Suite(
            "camera",
            "camera pose offsets at RoboLab's ranges: external cameras only, the wrist camera only, both",
            {name: f"camera={name}" for name in ("external", "wrist", "both")},
        ),
        Suite(
            "objects",
            "object x, y offsets of up to 10, 20 and 30 cm from the layout (collision-aware)",
            {name: f"objects={name}" for name in ("10cm", "20cm", "30cm")},
        ),
    ]
    return {suite.name: Suite(suite.name, suite.description, {BASELINE: "", **suite.conditions}) for suite in made}


def suite_conditions(argument: str) -> tuple[Suite, dict[str, str]]:
    """The suite and conditions of `--suite NAME` or `--suite NAME:COND/COND` (conditions in the suite's order)."""
    name, _, chosen = argument.partition(":")
    known = suites()
    if name not in known:
        raise UnknownNameError("suite", name, known)
    suite = known[name]
    if not chosen:
        return suite, dict(suite.conditions)
    wanted = [c.strip() for c in chosen.split("/") if c.strip()]
    for condition in wanted:
        if condition not in suite.conditions:
            raise VariationError(
                f"--suite {argument}: unknown condition '{condition}' of suite {name} (its "
                f"conditions: {', '.join(suite.conditions)})"
            )
    return suite, {c: text for c, text in suite.conditions.items() if c in wanted}


SUITE_CSV, SUITE_MD = "suite.csv", "suite.md"
ALL_TASKS_ROW = "all tasks"


def suite_summary(out_dir: Path, suite: Suite, conditions: list[str], policy: str) -> Path:
    """Write OUT/suite.csv (one row per condition and task: episodes, success rate with its 95 % Beta interval,
    mean score) and OUT/suite.md (tasks x conditions) from the condition folders' episodes; returns the Markdown."""
    import pandas as pd

    from robolab_ms.analysis.tables import success_interval, to_markdown
    from robolab_ms.eval.results import read_results

    rows = []
    for condition in conditions:
        results = [r for r in read_results(out_dir / condition) if r.policy == policy]
        groups: dict[str, list] = {ALL_TASKS_ROW: results}
        for result in results:
            groups.setdefault(result.task, []).append(result)
        for task, group in groups.items():
            successes = sum(r.success for r in group)
            low, high = success_interval(successes, len(group)) if group else (float("nan"), float("nan"))
            rows.append(
                {
                    "suite": suite.name,
                    "condition": condition,
                    "settings": suite.conditions[condition],
                    "task": task,
                    "episodes": len(group),
                    "success_%": round(100 * successes / len(group), 1) if group else float("nan"),
                    "success_ci95_low_%": round(100 * low, 1),
                    "success_ci95_high_%": round(100 * high, 1),
                    "score": round(sum(r.score for r in group) / len(group), 3) if group else float("nan"),
                }
            )
    table = pd.DataFrame(rows)
    table.to_csv(out_dir / SUITE_CSV, index=False)
    parts = [f"# Suite {suite.name} ({policy})\n", f"{suite.description}.\n", "## Success % [95 % interval]\n"]
    for value, title in (("success", None), ("score", "## Mean score\n")):
        if title:
            parts.append(title)
        shown = table.copy()
        if value == "success":
            shown["cell"] = shown.apply(
                lambda r: f"{r['success_%']:.0f} [{r['success_ci95_low_%']:.0f}, {r['success_ci95_high_%']:.0f}]",
                axis=1,
            )
        else:
            shown["cell"] = shown["score"].map(lambda v: f"{v:.2f}")
        pivot = shown.pivot(index="task", columns="condition", values="cell").reindex(columns=conditions)
        order = [ALL_TASKS_ROW] + sorted(t for t in pivot.index if t != ALL_TASKS_ROW)
        parts.append(to_markdown(pivot.reindex(order).reset_index()) + "\n")
    markdown = out_dir / SUITE_MD
    markdown.write_text("\n".join(parts), encoding="utf-8")
    return markdown
