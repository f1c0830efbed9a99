"""Episodes of one or more results folders as one table, with what each task asks of a policy.

`load_runs` is the single entry point of the analysis commands (`robolab analyze`, `sensitivity`, `leaderboard`):
one row per episode, the columns of `tables.episode_frame` (outcome, metrics in table units, event counts, drawn
variation parameters) plus:

| column | what |
|---|---|
| `run` | the results folder the episode came from (its name; the path where names repeat) |
| `scene`, `attributes`, `axes` | the task's scene, its attributes and competency axes (`;`-separated, sorted) |
| `difficulty`, `difficulty_score`, `num_subtasks` | RoboLab's difficulty label and rating (subtasks + skill weight) |
| `num_objects` | bodies in the task's scene (targets and distractors) |
| `episode_seconds` | the task's time limit |
| `time_to_success_s` | seconds until success (`success_step` / 15 Hz); NaN for failures |

Task columns come from the task files known now (shipped, `$ROBOLAB_CONTENT`, `--content`), else from RoboLab-120's
facts (robolab_ms/tasks/robolab120.yaml); a task that neither describes keeps them empty and is named in
`RunSet.unknown_tasks`. A RoboLab run folder (its `episode_results.jsonl`) is read by `robolab_results`: its
episodes carry `simulator` robolab-isaac and the policy name `<policy>@robolab-isaac`.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from robolab_ms.analysis.robolab_results import (
    ROBOLAB_RESULTS_FILE,
    is_robolab_folder,
    read_robolab_folder,
    robolab120_task_rows,
)
from robolab_ms.analysis.tables import episode_frame
from robolab_ms.errors import RoboLabError
from robolab_ms.eval.results import EPISODES_FILE, EpisodeResult, read_results
from robolab_ms.tasks.spec import CONTROL_HZ

TASK_COLUMNS = (
    "scene",
    "attributes",
    "axes",
    "difficulty",
    "difficulty_score",
    "num_subtasks",
    "num_objects",
    "episode_seconds",
)


@dataclass
class RunSet:
    """Episodes of several results folders: `episodes` has one row per episode (columns in the module docstring)."""

    episodes: pd.DataFrame
    folders: list[Path]
    unknown_tasks: list[str] = field(default_factory=list)

    @property
    def policies(self) -> list[str]:
        return sorted(self.episodes["policy"].unique()) if len(self.episodes) else []


def task_table(tasks: Iterable[str] | None = None) -> pd.DataFrame:
    """One row per known task (index: task name) with the task columns of the module docstring. `tasks` limits
    the rows to those names; a name no task file describes takes RoboLab-120's facts of that task
    (robolab_ms/tasks/robolab120.yaml), and names neither knows are left out."""
    from robolab_ms.tasks.spec import load_all_tasks, load_task, task_names

    if tasks is None:
        specs = load_all_tasks()
    else:  # only the tasks asked for: reading every task file and scene takes seconds
        known = set(task_names())
        specs = [load_task(name) for name in sorted(set(tasks)) if name in known]
    rows = []
    for spec in specs:
        rows.append(
            {
                "task": spec.name,
                "scene": spec.scene.name,
                "attributes": ";".join(sorted(spec.attributes)),
                "axes": ";".join(spec.axes),
                "difficulty": spec.difficulty,
                "difficulty_score": spec.difficulty_score,
                "num_subtasks": spec.num_subtasks,
                "num_objects": len(spec.scene.objects),
                "episode_seconds": spec.episode_seconds,
            }
        )
    if tasks is not None:
        rows += robolab120_task_rows(set(tasks) - {row["task"] for row in rows})
    return pd.DataFrame(rows, columns=["task", *TASK_COLUMNS]).set_index("task")


def load_runs(folders: Sequence[str | Path], task_info: pd.DataFrame | None = None) -> RunSet:
    """Every complete episode of `folders` (results folders of `robolab eval`), one row each, with task columns.

    `task_info` (index: task name, columns as `task_table`) replaces the task files as the source of the task
    columns, e.g. for results of tasks defined elsewhere. An episode present in two folders (same task, variant,
    robot, policy and seed) counts once, from the folder given last."""
    paths = [Path(folder) for folder in folders]
    if not paths:
        raise RoboLabError("no results folder given: name one or more folders written by `robolab eval --out DIR`")
    results: dict[tuple, tuple[str, EpisodeResult]] = {}
    labels = run_labels(paths)
    for path, label in zip(paths, labels):
        if not path.is_dir():
            what = "a file, not a folder" if path.exists() else "no such folder"
            raise RoboLabError(f"{path}: {what}; give a folder written by `robolab eval --out DIR`")
        if is_robolab_folder(path):
            folder_results = read_robolab_folder(path)
        elif (path / EPISODES_FILE).exists():
            folder_results = read_results(path)
        else:
            raise RoboLabError(
                f"{path}: no {EPISODES_FILE} in it; is it a results folder of `robolab eval`? (A "
                f"RoboLab run folder has {ROBOLAB_RESULTS_FILE}.)"
            )
        for result in folder_results:
            results[result.key()] = (label, result)
    if not results:
        raise RoboLabError(f"no complete episode in {', '.join(str(p) for p in paths)}; run `robolab eval` first")
    episodes = episode_frame([result for _, result in results.values()])
    episodes.insert(0, "run", [label for label, _ in results.values()])
    names = sorted(episodes["task"].unique())
    if task_info is None:
        task_info = task_table(names)
    unknown = [name for name in names if name not in task_info.index]
    if unknown:
        warnings.warn(
            f"no task file describes {', '.join(unknown)}: their scene, attributes and difficulty stay "
            "empty (pass --content DIR with their task files)",
            stacklevel=2,
        )
    episodes = episodes.join(task_info.reindex(columns=list(TASK_COLUMNS)), on="task")
    episodes["time_to_success_s"] = pd.to_numeric(episodes["success_step"], errors="coerce") / CONTROL_HZ
    return RunSet(episodes=episodes.reset_index(drop=True), folders=paths, unknown_tasks=unknown)


def run_labels(paths: list[Path]) -> list[str]:
    """The folder names, or the paths as given where two folders share a name."""
    names = [path.resolve().name for path in paths]
    return [name if names.count(name) == 1 else str(path) for name, path in zip(names, paths)]


def explode_column(episodes: pd.DataFrame, column: str) -> pd.DataFrame:
    """One row per (episode, value) of a `;`-separated column such as `attributes` or `axes`: an episode of a task
    with two attributes counts once under each."""
    split = episodes.assign(**{column: episodes[column].fillna("").str.split(";")}).explode(column)
    return split[split[column] != ""]
