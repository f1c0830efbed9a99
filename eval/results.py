"""The results format: one JSON line per episode in `episodes.jsonl`, appended and flushed as each episode ends.

Every line records the tuple that defines its episode (task, instruction variant, robot, policy, seed, and the
variation settings with the parameters they drew), so any episode can be replayed, and the outcome (success, score,
progress, steps, timings, error) with its trajectory metrics. Tables are derived from these lines, never the other
way round. Lines of results version 1 still load; their trajectory metrics, computed before RoboLab's definitions
were adopted, come back under the names of `eval.metrics.LEGACY_METRIC_NAMES`. A run interrupted mid-line leaves at
most one partial last line, which `read_results` ignores, so a rerun resumes after the last complete episode; a
complete line that is not an episode is an error naming the line and the field.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.errors import ResultsError, RoboLabError
from robolab_ms.eval.metrics import legacy_metrics

EPISODES_FILE = "episodes.jsonl"
WRITER_LOCK_FILE = ".writer.lock"  # held by the run that writes the folder (see exclusive_writer)
# 2: trajectory metrics as RoboLab defines them (eval.metrics); lines of version 1 load their metrics under the
# names of eval.metrics.LEGACY_METRIC_NAMES
RESULTS_VERSION = 2
SIMULATOR = "robolab_ms"  # the `simulator` of the episodes `robolab eval` runs
# the fields of a result line that measure time: they differ from run to run of the very same episode
TIMING_FIELDS = frozenset(
    {"wall_seconds", "inference_ms_mean", "inference_ms_p95", "inference_ms_max", "env_step_ms", "steps_per_second"}
)


@dataclass
class EpisodeResult:
    task: str
    instruction_variant: str
    instruction: str
    robot: str
    policy: str
    seed: int
    success: bool
    score: float
    progress: float
    steps: int
    max_steps: int
    success_step: int | None
    wall_seconds: float
    error: str | None = None
    events: list[dict[str, Any]] = field(default_factory=list)
    metrics: dict[str, float | None] = field(default_factory=dict)  # eval.metrics.METRIC_KEYS; None = not defined
    event_counts: dict[str, int] = field(default_factory=dict)  # event type -> how often it fired
    event_objects: dict[str, list[str]] = field(default_factory=dict)  # object event type -> objects it fired for
    recording: str | None = None  # the episode's trajectory file (.h5, next to its .json), relative to the folder
    video: str | None = None  # the episode's mp4, relative to the results folder
    endpoint: str | None = None  # where the policy ran: in-process, ws://host:port, tcp://host:port, module:factory
    policy_metadata: dict[str, Any] = field(default_factory=dict)  # what the policy (its server) says about itself
    queries: int = 0  # times the policy was asked (a remote policy: once per executed chunk)
    inference_ms_mean: float | None = None  # time per query, as the runner sees it (round trip for a server)
    inference_ms_p95: float | None = None
    env_step_ms: float | None = None  # mean time of one env step (physics, task logic, cameras)
    steps_per_second: float | None = None  # control steps per second of wall time, reset included
    clipped_steps: int = 0  # steps whose arm joint targets were outside the robot's limits and were clipped
    variations: str | None = None  # the variation settings (`--vary` text; None: the scenes as they are)
    condition: str | None = None  # the suite condition the episode ran under (`--suite`), if any
    variation: dict[str, float | int | str] = field(default_factory=dict)  # drawn parameters, flat (docs/variations.md)
    simulator: str = SIMULATOR  # what ran the episode: robolab_ms, or robolab-isaac for a RoboLab run folder's line
    # real time (`robolab eval --realtime`, docs/policies.md): the policy's latency passed in simulated time
    realtime: bool = False  # False: the simulation waited for every reply (older lines have no such field)
    held_steps: int | None = None  # steps the arm held its last target, no action having arrived; None: not real time
    inference_ms_max: float | None = None  # the longest query (with inference_ms_mean: the latency in real time)
    version: int = RESULTS_VERSION

    def key(self) -> tuple:
        return episode_key(self.task, self.instruction_variant, self.robot, self.policy, self.seed)


def episode_key(task: str, variant: str, robot: str, policy: str, seed: int) -> tuple:
    return (task, variant, robot, policy, seed)


def append_result(out_dir: Path, result: EpisodeResult) -> None:
    """Append one episode and make sure it is on disk before returning."""
    path = Path(out_dir) / EPISODES_FILE
    line = json.dumps(asdict(result), sort_keys=True)
    with path.open("a", encoding="utf-8") as handle:
        _lock(handle.fileno())  # one appender at a time, across processes too (released when the file closes)
        if handle.tell() > 0 and not _ends_with_newline(path):
            handle.write("\n")  # a previous run died mid-line: start a fresh line
        handle.write(line + "\n")
        handle.flush()
        os.fsync(handle.fileno())


def _lock(fd: int, wait: bool = True) -> bool:
    """Take the exclusive advisory lock of an open file (POSIX; elsewhere nothing); False if `wait` is off and
    another process holds it."""
    try:
        import fcntl
    except ImportError:
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except BlockingIOError:
        return False
    return True


@contextmanager
def exclusive_writer(out_dir: Path) -> Iterator[None]:
    """Hold the results folder for one run: a second `robolab eval` on the same folder at the same time (which
    would run the same episodes twice) stops with an error instead. A killed run's hold ends with its process."""
    path = Path(out_dir) / WRITER_LOCK_FILE
    with path.open("a+", encoding="utf-8") as handle:
        if not _lock(handle.fileno(), wait=False):
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            raise RoboLabError(
                f"{out_dir} is being written by {holder}; wait for that run to end or choose another --out"
            )
        handle.seek(0)
        handle.truncate()
        handle.write(f"robolab eval (pid {os.getpid()})\n")
        handle.flush()
        yield


def _ends_with_newline(path: Path) -> bool:
    with path.open("rb") as handle:
        handle.seek(-1, os.SEEK_END)
        return handle.read(1) == b"\n"


def read_results(out_dir: Path) -> list[EpisodeResult]:
    """All complete episode lines of a results folder. When an episode has several lines (an errored one run again
    with --retry-errors), the last one counts.

    A line that is not complete JSON (a run killed while writing it; blank lines) is skipped. A complete line must
    be an episode: a JSON object with the fields of `EpisodeResult`, each of its kind; fields it does not know are
    ignored, and fields added after the line was written take their defaults (as does `null` for them). NaN in an
    optional number (a metric, a timing) means undefined, as `null`; a NaN or null variation parameter was not
    drawn. Anything else raises `ResultsError` naming the file, the line and the field."""
    path = Path(out_dir) / EPISODES_FILE
    if not path.exists():
        return []
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RoboLabError(
            f"{path}: cannot be read ({exc.strerror or exc}); give a results folder written by `robolab eval --out DIR`"
        ) from None
    results: dict[tuple, EpisodeResult] = {}
    for number, raw in enumerate(data.split(b"\n"), start=1):
        try:
            record = json.loads(raw.decode("utf-8", errors="replace"))
        except json.JSONDecodeError:
            continue  # a partial line (or a blank one)
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ResultsError(path, number, "", f"is not UTF-8 text (byte {exc.start + 1})", LINE_FIX) from None
        result = episode_from_record(record, path, number)
        if record.get("version", 1) < 2:
            result.metrics, result.version = legacy_metrics(result.metrics), 1
        results[result.key()] = result
    return list(results.values())


LINE_FIX = (
    "Correct the line or delete it (a later `robolab eval` with the same options runs that episode again); "
    "docs/results.md lists the fields"
)


# Value checkers of the results format, shared by the readers of result lines and of recordings: each returns the
# value (null and NaN as None for `optional` ones) or raises InvalidValue saying what it is and what it should be.


class InvalidValue(ValueError):
    """A value that is not of its field's kind; the message says what it is and what it should be, `key` which
    entry of an object field it is (metrics.ee_sparc)."""

    def __init__(self, problem: str, key: str = "") -> None:
        super().__init__(problem)
        self.key = key


def shown(value: Any) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value).replace("nan", "NaN").replace("inf", "Infinity")
    text = json.dumps(value)
    kind = {str: "text", list: "a list", dict: "an object"}.get(type(value))
    text = text if len(text) <= 40 else text[:37] + "..."
    return f"{text} ({kind})" if kind else text


def as_text(value: Any) -> str:
    if not isinstance(value, str):
        raise InvalidValue(f"is {shown(value)}, expected text")
    return value


def as_name(value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise InvalidValue(f"is {shown(value)}, expected a non-empty name")
    return value


def as_integer(value: Any) -> int:
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if not isinstance(value, int) or isinstance(value, bool):
        raise InvalidValue(f"is {shown(value)}, expected a whole number")
    return value


def as_count(value: Any) -> int:
    number = as_integer(value)
    if number < 0:
        raise InvalidValue(f"is {number}, expected a count of 0 or more")
    return number


def as_flag(value: Any) -> bool:
    if not isinstance(value, bool):
        raise InvalidValue(f"is {shown(value)}, expected true or false")
    return value


def as_number(value: Any) -> float | int:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise InvalidValue(f"is {shown(value)}, expected a finite number")
    return value


def optional(kind: Callable[[Any], Any]) -> Callable[[Any], Any]:
    def check(value: Any) -> Any:
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return None
        return kind(value)

    return check


def as_mapping(value: Any) -> dict:
    if not isinstance(value, dict):
        raise InvalidValue(f"is {shown(value)}, expected an object")
    return value


def each(kind: Callable[[Any], Any], drop_missing: bool = False) -> Callable[[Any], dict]:
    """An object whose values are each of `kind` (with `drop_missing`, null and NaN values are left out)."""

    def check(value: Any) -> dict:
        checked = {}
        for key, item in as_mapping(value).items():
            if drop_missing and (item is None or (isinstance(item, float) and math.isnan(item))):
                continue
            try:
                checked[key] = kind(item)
            except InvalidValue as exc:
                raise InvalidValue(str(exc), key) from None
        return checked

    return check


def as_names(value: Any) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
        raise InvalidValue(f"is {shown(value)}, expected a list of names")
    return value


def as_events(value: Any) -> list[dict[str, Any]]:
    if not isinstance(value, list):
        raise InvalidValue(f"is {shown(value)}, expected a list of events")
    for index, event in enumerate(value):
        if not isinstance(event, dict) or not isinstance(event.get("type"), str):
            raise InvalidValue(
                f"item {index} is {shown(event)}, expected an event such as "
                '{"step": 12, "type": "target_dropped", "object": "banana"}'
            )
    return value


def as_parameter(value: Any) -> float | int | str | bool:
    if isinstance(value, (str, bool)):
        return value
    try:
        return as_number(value)
    except InvalidValue:
        raise InvalidValue(f"is {shown(value)}, expected a number or a name") from None


# field of EpisodeResult -> what its value must be (null: the default, for fields that have one)
FIELD_KINDS: dict[str, Callable[[Any], Any]] = {
    "task": as_name, "instruction_variant": as_name, "instruction": as_text, "robot": as_name, "policy": as_name,
    "seed": as_integer, "success": as_flag, "score": as_number, "progress": as_number, "steps": as_count,
    "max_steps": as_count, "success_step": optional(as_count), "wall_seconds": as_number, "error": optional(as_text),
    "events": as_events, "metrics": each(optional(as_number)), "event_counts": each(as_count),
    "event_objects": each(as_names), "recording": optional(as_text), "video": optional(as_text),
    "endpoint": optional(as_text), "policy_metadata": as_mapping, "queries": as_count,
    "inference_ms_mean": optional(as_number), "inference_ms_p95": optional(as_number),
    "env_step_ms": optional(as_number), "steps_per_second": optional(as_number), "clipped_steps": as_count,
    "variations": optional(as_text), "condition": optional(as_text), "variation": each(as_parameter, drop_missing=True),
    "simulator": as_name, "realtime": as_flag, "held_steps": optional(as_count),
    "inference_ms_max": optional(as_number), "version": as_integer,
}  # fmt: skip


def episode_from_record(record: Any, file: Path, line: int) -> EpisodeResult:
    """The episode of one parsed line (`read_results` says what is accepted); ResultsError otherwise."""
    if not isinstance(record, dict):
        raise ResultsError(file, line, "", f"is {shown(record)}, not an episode (a JSON object)", LINE_FIX)
    values: dict[str, Any] = {}
    for spec in fields(EpisodeResult):
        has_default = spec.default is not MISSING or spec.default_factory is not MISSING
        if spec.name not in record:
            if not has_default:
                raise ResultsError(file, line, spec.name, "is missing; every episode line has it", LINE_FIX)
            continue
        value = record[spec.name]
        if value is None and has_default and spec.name not in _NULLABLE:
            continue  # null for a field with a default: the default
        try:
            values[spec.name] = FIELD_KINDS[spec.name](value)
        except InvalidValue as exc:
            name = f"{spec.name}.{exc.key}" if exc.key else spec.name
            raise ResultsError(file, line, name, str(exc), LINE_FIX) from None
    return EpisodeResult(**values)


_NULLABLE = {spec.name for spec in fields(EpisodeResult) if spec.default is None}


def to_json_value(value: Any) -> Any:
    """A value as JSON can hold it: mappings and sequences walked, numpy arrays and scalars to Python, bytes to text,
    NaN to null, anything else unknown to its text."""
    if isinstance(value, dict):
        return {str(key): to_json_value(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_json_value(item) for item in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, float) and value != value:
        return None
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    return str(value)
