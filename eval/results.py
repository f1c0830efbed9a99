"""The results format: one JSON line per episode in `episodes.jsonl`, appended and flushed as each episode ends.

Every line records the tuple that defines its episode (task, instruction variant, robot, policy, seed, and the
variation settings with the parameters they drew), so any episode can be replayed, and the outcome (success, score,
progress, steps, timings, error) with its trajectory metrics. Tables are derived from these lines, never the other
way round. Lines of results version 1 still load; their trajectory metrics, computed before RoboLab's definitions
were adopted, come back under the names of `eval.metrics.LEGACY_METRIC_NAMES`. A run interrupted mid-line leaves at
most one partial last line, which `read_results` ignores, so a rerun resumes after the last complete episode.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.metrics import legacy_metrics

EPISODES_FILE = "episodes.jsonl"
WRITER_LOCK_FILE = ".writer.lock"  # held by the run that writes the folder (see exclusive_writer)
# 2: trajectory metrics as RoboLab defines them (eval.metrics); lines of version 1 load their metrics under the
# names of eval.metrics.LEGACY_METRIC_NAMES
RESULTS_VERSION = 2
SIMULATOR = "robolab_ms"  # the `simulator` of the episodes `robolab eval` runs
# the fields of a result line that measure time: they differ from run to run of the very same episode
TIMING_FIELDS = frozenset({"wall_seconds", "inference_ms_mean", "inference_ms_p95", "inference_ms_max", "env_step_ms",
                           "steps_per_second"})


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
            raise RoboLabError(f"{out_dir} is being written by {holder}; wait for that run to end or choose another "
                               "--out")  # fmt: skip
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
    """All complete episode lines of a results folder (partial or foreign lines are skipped). When an episode
    has several lines (an errored one run again with --retry-errors), the last one counts."""
    path = Path(out_dir) / EPISODES_FILE
    if not path.exists():
        return []
    known = {f.name for f in fields(EpisodeResult)}
    results: dict[tuple, EpisodeResult] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            record = json.loads(line)
            result = EpisodeResult(**{k: v for k, v in record.items() if k in known})
        except (json.JSONDecodeError, TypeError, AttributeError):
            continue
        if record.get("version", 1) < 2 and isinstance(result.metrics, dict):
            result.metrics, result.version = legacy_metrics(result.metrics), 1
        results[result.key()] = result
    return list(results.values())


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
