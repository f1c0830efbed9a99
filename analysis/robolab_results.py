"""RoboLab's own result files: a run folder of NVIDIA's RoboLab (Isaac Lab) read as our episode results, so that
`robolab analyze` and `robolab leaderboard` put a policy's RoboLab run beside its robolab_ms run.

A RoboLab run folder `<timestamp>_<policy>[_<instruction_type>]/` holds `episode_results.jsonl`, one JSON object
per episode (env_name, task_name, run_name, run, episode, env_id, policy, instruction, instruction_type,
attributes, success, score, reason, episode_step, duration, dt, metrics, events, timing). `read_robolab_folder`
turns each line into an `EpisodeResult`:

| ours | from RoboLab's line |
|---|---|
| `task` | `task_name` (else `env_name` up to its first `_`) without a trailing `Task` where the rest is a known task name (RoboLab's class `BananaInBowlTask` is our `BananaInBowl`) |
| `instruction_variant` | `instruction_type`; else the folder name's suffix `_default`, `_vague` or `_specific`; else `default` |
| `instruction`, `success` | the same fields |
| `robot` | `droid` (RoboLab-120's robot) |
| `policy` | `policy` + `@robolab-isaac` (so it never merges with the same policy's robolab_ms episodes) |
| `seed` | `episode` (RoboLab's run x environments + environment); where one task and variant repeat an episode number (several `env_name`s of one task), 0, 1, ... in the order of (`env_name`, `episode`) |
| `score`, `progress` | `score`; null: 1 for a success, NaN for a failure |
| `steps` | `episode_step` |
| `success_step` | for a success, the episode's `duration` (else `episode_step` x `dt`) in our 15 Hz steps |
| `max_steps` | RoboLab's time limit for the task (robolab120.yaml) x 15, else `steps` |
| `wall_seconds`, `inference_ms_mean`, `env_step_ms`, `steps_per_second` | `timing`: `wall_total_s`, `policy_inference_avg_ms`, `env_step_avg_ms`, `it_per_sec` |
| `metrics` | `metrics` (RoboLab's names are ours, eval.metrics), or the same keys at the top level of the line |
| `event_counts`, `event_objects` | `events`, RoboLab's event names turned into ours (`EVENT_NAMES`); a list counts its entries; `wrong_objects_grabbed` lists the wrong objects; RoboLab's `WRONG_OBJECT_DETACHED` has no counterpart and is left out |
| `condition` | what `env_name` adds after the task, e.g. `RedLight` of `BananaInBowlTask_RedLight` |
| `variation` | the other top-level fields with a single value (e.g. `lighting_color` of RoboLab's lighting runs) |
| `simulator` | `robolab-isaac` |

When an episode has several lines (same `env_name`, variant and `episode`), the last one counts. A line cut short
(not valid JSON: an interrupted run) is skipped with a warning; a line that is JSON but not an episode stops with
an error naming the file, the line and the field.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.metrics import METRIC_KEYS
from robolab_ms.eval.results import EPISODES_FILE, EpisodeResult
from robolab_ms.tasks.events import EVENT_TYPES
from robolab_ms.tasks.spec import CONTROL_HZ, INSTRUCTION_VARIANTS

ROBOLAB_RESULTS_FILE = "episode_results.jsonl"
ROBOLAB_SIMULATOR = "robolab-isaac"
ROBOLAB_ROBOT = "droid"
# RoboLab's event names (status code names without `_FAILURE`, lower-cased) -> ours; the others are the same name
EVENT_NAMES = {
    "wrong_object_grabbed": "wrong_object_grasped",
    "target_object_dropped": "target_dropped",
    "multiple_objects_grabbed": "multiple_objects_grasped",
}
WRONG_OBJECTS_KEY = "wrong_objects_grabbed"  # RoboLab's list of the wrong objects grasped
# top-level fields of RoboLab's lines that are not variation parameters
KNOWN_FIELDS = {"env_name", "task_name", "run_name", "run", "episode", "env_id", "policy", "instruction",
                "instruction_type", "attributes", "success", "score", "reason", "episode_step", "duration", "dt",
                "metrics", "events", "timing", "data_dir", *METRIC_KEYS}  # fmt: skip
_FOLDER_NAME = re.compile(r"^\d{4}-\d{2}-\d{2}_\d{2}-\d{2}-\d{2}_(?P<rest>.+)$")


def is_robolab_folder(path: Path) -> bool:
    """Whether `path` is a RoboLab run folder (its `episode_results.jsonl`, no `episodes.jsonl` of ours)."""
    return (Path(path) / ROBOLAB_RESULTS_FILE).is_file() and not (Path(path) / EPISODES_FILE).exists()


def robolab_policy_label(policy: str) -> str:
    """The policy name RoboLab's episodes of `policy` carry in our tables."""
    return f"{policy}@{ROBOLAB_SIMULATOR}"


@dataclass
class _Line:
    """One episode line of a RoboLab file, checked, before seeds are assigned."""

    number: int  # line number in the file (1-based)
    env_name: str
    episode: int | None
    result: EpisodeResult


def read_robolab_folder(folder: str | Path) -> list[EpisodeResult]:
    """Every episode of a RoboLab run folder as `EpisodeResult`s (the module docstring says how fields map)."""
    folder = Path(folder)
    path = folder / ROBOLAB_RESULTS_FILE
    variant_of_folder, policy_of_folder = _folder_defaults(folder.name)
    lines: dict[tuple, _Line] = {}
    for number, text in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if not text.strip():
            continue
        try:
            record = json.loads(text)
        except json.JSONDecodeError:
            warnings.warn(f"{path} line {number}: not complete JSON (an interrupted run?); skipped", stacklevel=2)
            continue
        line = _read_line(record, _Where(path, number), variant_of_folder, policy_of_folder)
        lines[
            (line.env_name, line.result.instruction_variant, line.episode if line.episode is not None else -number)
        ] = line
    return _assign_seeds(list(lines.values()))


@dataclass(frozen=True)
class _Where:
    path: Path
    line: int

    def error(self, field: str, problem: str, fix: str) -> RoboLabError:
        return RoboLabError(f"{self.path} line {self.line}: field '{field}': {problem}. {fix}")


def _folder_defaults(name: str) -> tuple[str | None, str | None]:
    """The instruction type and policy a RoboLab folder name `<timestamp>_<policy>[_<instruction_type>]` gives."""
    match = _FOLDER_NAME.match(name)
    rest = match.group("rest") if match else name
    for variant in INSTRUCTION_VARIANTS:
        if rest.endswith(f"_{variant}"):
            return variant, rest[: -len(variant) - 1]
    return None, rest if match else None


def _read_line(record: Any, where: _Where, variant_of_folder: str | None, policy_of_folder: str | None) -> _Line:
    if not isinstance(record, dict):
        raise RoboLabError(
            f"{where.path} line {where.line}: not a JSON object; each line of {ROBOLAB_RESULTS_FILE} "
            "is one episode's object as RoboLab writes it"
        )
    env_name = _text(record, "env_name", where, required=False)
    task_name = _text(record, "task_name", where, required=False)
    if not env_name and not task_name:
        raise where.error("task_name", "missing (and no env_name)", "RoboLab writes both; give at least one")
    task = task_of(task_name or env_name.split("_")[0])
    env_name = env_name or task_name
    suffix = env_name.split("_", 1)[1] if "_" in env_name else None
    variant = _text(record, "instruction_type", where, required=False) or variant_of_folder or "default"
    policy = _text(record, "policy", where, required=False) or policy_of_folder
    if not policy:
        raise where.error("policy", "missing", "name the policy in each line, as RoboLab does")
    success = record.get("success")
    if not isinstance(success, bool):
        raise where.error("success", f"{success!r} is not true or false", "RoboLab writes a JSON boolean")
    steps = _number(record, "episode_step", where, integer=True)
    steps = 0 if steps is None else int(steps)
    dt = _number(record, "dt", where)
    duration = _number(record, "duration", where)
    if duration is None and dt is not None:
        duration = steps * dt
    score = _number(record, "score", where)
    if score is None:
        score = 1.0 if success else math.nan
    timing = record.get("timing") or {}
    if not isinstance(timing, dict):
        raise where.error("timing", "not a JSON object", 'write {"wall_total_s": ..., ...} or leave it out')
    episode = _number(record, "episode", where, integer=True)
    result = EpisodeResult(
        task=task,
        instruction_variant=variant,
        instruction=_text(record, "instruction", where, required=False) or "",
        robot=ROBOLAB_ROBOT,
        policy=robolab_policy_label(policy),
        seed=-1,  # assigned by _assign_seeds
        success=success,
        score=score,
        progress=score,
        steps=steps,
        max_steps=_time_limit_steps(task) or steps,
        success_step=(round(duration * CONTROL_HZ) if duration is not None else steps) if success else None,
        wall_seconds=_timing(timing, "wall_total_s", where) or 0.0,
        metrics=_metrics(record, where),
        inference_ms_mean=_timing(timing, "policy_inference_avg_ms", where),
        env_step_ms=_timing(timing, "env_step_avg_ms", where),
        steps_per_second=_timing(timing, "it_per_sec", where),
        condition=suffix,
        variation={
            key: value
            for key, value in record.items()
            if key not in KNOWN_FIELDS and isinstance(value, (str, int, float)) and not isinstance(value, bool)
        },
        simulator=ROBOLAB_SIMULATOR,
    )
    result.event_counts, result.event_objects = _events(record.get("events"), where)
    return _Line(where.line, env_name, None if episode is None else int(episode), result)


def _assign_seeds(lines: list[_Line]) -> list[EpisodeResult]:
    """Seeds: RoboLab's episode numbers where they are distinct within a task and variant, else 0, 1, ..."""
    groups: dict[tuple[str, str], list[_Line]] = {}
    for line in lines:
        groups.setdefault((line.result.task, line.result.instruction_variant), []).append(line)
    for members in groups.values():
        episodes = [line.episode for line in members]
        if None not in episodes and len(set(episodes)) == len(episodes):
            for line in members:
                line.result.seed = line.episode
        else:
            ordered = sorted(
                members,
                key=lambda line: (line.env_name, line.episode if line.episode is not None else math.inf, line.number),
            )
            for seed, line in enumerate(ordered):
                line.result.seed = seed
    return [line.result for line in lines]


def task_of(name: str) -> str:
    """Our name of a RoboLab task: without a trailing `Task` where the rest names a known task."""
    if name.endswith("Task") and name[:-4] in _known_tasks():
        return name[:-4]
    return name


@lru_cache(maxsize=1)
def _known_tasks() -> frozenset[str]:
    from robolab_ms.tasks.spec import task_names

    return frozenset(task_names()) | frozenset(_robolab_facts())


@lru_cache(maxsize=1)
def _robolab_facts() -> dict[str, Any]:
    """RoboLab-120's facts per task name (robolab_ms/tasks/robolab120.yaml)."""
    from robolab_ms.tasks.summary import robolab_facts

    return {facts.name: facts for facts in robolab_facts()}


def robolab120_task_rows(names: Iterable[str]) -> list[dict[str, Any]]:
    """RoboLab-120's facts of those of `names` it lists, as rows of `runs.task_table`: for tasks RoboLab has and
    our task files do not."""
    rows = []
    for name in sorted(set(names) & set(_robolab_facts())):
        facts = _robolab_facts()[name]
        rows.append(
            {
                "task": name,
                "scene": facts.scene,
                "attributes": ";".join(sorted(facts.attributes)),
                "axes": ";".join(facts.axes),
                "difficulty": facts.difficulty,
                "difficulty_score": facts.difficulty_score,
                "num_subtasks": facts.subtasks,
                "num_objects": facts.objects,
                "episode_seconds": facts.episode_seconds,
            }
        )
    return rows


def _time_limit_steps(task: str) -> int | None:
    facts = _robolab_facts().get(task)
    return None if facts is None else round(facts.episode_seconds * CONTROL_HZ)


def _text(record: dict, key: str, where: _Where, required: bool = True) -> str | None:
    value = record.get(key)
    if value is None and not required:
        return None
    if not isinstance(value, str):
        raise where.error(key, f"{value!r} is not text", "RoboLab writes a JSON string")
    return value


def _number(record: dict, key: str, where: _Where, integer: bool = False, label: str | None = None) -> float | None:
    """A number field (None when absent or null; NaN too, unless a whole number is asked for)."""
    value = record.get(key)
    if value is None or (not integer and isinstance(value, float) and math.isnan(value)):
        return None
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or (integer and value != int(value))
    ):
        raise where.error(
            label or key,
            f"{value!r} is not {'a whole number' if integer else 'a finite number'}",
            "write a JSON number or null",
        )
    return float(value)


def _timing(timing: dict, key: str, where: _Where) -> float | None:
    return _number(timing, key, where, label=f"timing.{key}")


def _metrics(record: dict, where: _Where) -> dict[str, float | None]:
    metrics = record.get("metrics")
    if metrics is None:
        metrics = {}
    if not isinstance(metrics, dict):
        raise where.error("metrics", "not a JSON object", 'write {"ee_sparc": ..., ...} or leave it out')
    values: dict[str, float | None] = {}
    for key in METRIC_KEYS:
        source = metrics if key in metrics else record
        if key not in source:
            continue
        value = source[key]
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))):
            raise where.error(f"metrics.{key}", f"{value!r} is not a number", "write a JSON number or null")
        values[key] = None if value is None or not math.isfinite(value) else float(value)
    return values


def _events(events: Any, where: _Where) -> tuple[dict[str, int], dict[str, list[str]]]:
    """RoboLab's `events` as our event tallies: counts per event type, and objects per object event."""
    if events is None:
        return {}, {}
    if not isinstance(events, dict):
        raise where.error("events", "not a JSON object", 'write {"OBJECT_BUMPED": 2, ...} or leave it out')
    counts: dict[str, int] = {}
    objects: dict[str, list[str]] = {}
    wrong_objects: list[str] | None = None
    for name, value in events.items():
        if isinstance(value, list):
            names = _object_names(value, f"events.{name}", where)
            if name.lower() == WRONG_OBJECTS_KEY:
                wrong_objects = names
                continue
            count = len(names)
        elif isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 0 and value == int(value):
            count, names = int(value), []
        else:
            raise where.error(
                f"events.{name}",
                f"{value!r} is neither a count nor a list",
                "RoboLab writes a whole number, or a list of object names",
            )
        kind = EVENT_NAMES.get(name.lower(), name.lower())
        if kind not in EVENT_TYPES:
            continue
        counts[kind] = counts.get(kind, 0) + count
        if names:
            objects[kind] = sorted(set(objects.get(kind, [])) | set(names))
    if wrong_objects is not None:
        objects["wrong_object_grasped"] = sorted(set(wrong_objects))
        counts.setdefault("wrong_object_grasped", len(wrong_objects))  # the list alone: one grasp per entry
    return dict(sorted(counts.items())), dict(sorted(objects.items()))


def _object_names(values: Iterable[Any], field: str, where: _Where) -> list[str]:
    names = []
    for value in values:
        if not isinstance(value, str):
            raise where.error(field, f"{value!r} is not an object name", "list object names as JSON strings")
        names.append(value)
    return names
