"""The parent's schedule of a parallel run (`robolab eval --workers N` / `--ray`): which episode each worker runs
next, and which results are written, held back or dropped. Pure bookkeeping: it starts nothing and runs nothing.

The parent hands a worker the episodes of the task its environment holds first, so with `--episodes` every worker
builds each task's environment at most once.

Adaptive sampling (`--episodes-adaptive`) gives exactly the sequential run's episodes: seeds are handed out in
order, a little ahead of the results (at most one per worker beyond the seeds whose results are known, and the
first 10 at once); the success-rate rule is applied to the results in seed order, a result is written only once
every earlier seed's result is known and did not end the sampling, and results of seeds past the stopping point
are dropped with their files.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

from robolab_ms.eval.results import EpisodeResult, append_result, episode_key, read_results

if TYPE_CHECKING:
    from robolab_ms.eval.runner import EvalConfig


@dataclass(frozen=True)
class Job:
    """One episode to run: the task as given to --task (a name or a task file), its name, and the seed."""

    task: str
    name: str
    seed: int


@dataclass
class _TaskState:
    """The parent's view of one task: which seeds are known, running, held back, and whether sampling stopped."""

    task: str  # as given to --task
    name: str
    seeds: list[int]
    adaptive: bool
    known: dict[int, EpisodeResult] = field(default_factory=dict)  # results in the file (reused) or written
    running: set[int] = field(default_factory=set)
    held: dict[int, EpisodeResult] = field(default_factory=dict)  # adaptive: received, waiting for earlier seeds
    prefix: int = 0  # adaptive: how many seeds in order have known results (and did not stop the sampling)
    successes: int = 0  # adaptive: successes among them
    stopped: bool = False  # adaptive: the interval is narrow enough (or the most episodes ran)
    reported: bool = False  # the tables were written once the task was complete
    todo: deque = field(default_factory=deque)  # fixed episodes: seeds still to hand out


class Schedule:
    """Which episode each worker runs next, which results are written, held back or dropped (parent side)."""

    def __init__(
        self, config: EvalConfig, specs: list[Any], policy_name: str, out_dir: Path, workers: int, bar: tqdm
    ) -> None:
        from robolab_ms.eval.runner import ADAPTIVE_MIN_EPISODES

        self.config, self.out_dir, self.workers, self.bar = config, Path(out_dir), workers, bar
        done = {r.key(): r for r in read_results(out_dir)}
        self.always = min(ADAPTIVE_MIN_EPISODES, config.episodes_at_most)  # adaptive: seeds needed in any case
        self.tasks: list[_TaskState] = []
        for task, spec in zip(config.tasks, specs):
            seeds = list(range(config.first_seed, config.first_seed + config.episodes_at_most))
            state = _TaskState(task, spec.name, seeds, adaptive=bool(config.episodes_adaptive))
            for seed in seeds:
                result = done.get(episode_key(spec.name, config.instruction, config.robot, policy_name, seed))
                if result is not None and not (config.retry_errors and result.error is not None):
                    state.known[seed] = result
            if state.adaptive:
                self._advance(state)
            else:
                state.todo.extend(seed for seed in seeds if seed not in state.known)
                bar.update(len(state.known))
            self.tasks.append(state)

    def next_job(self, current_task: str | None) -> Job | None:
        """The next episode for a worker whose environment holds `current_task`: that task's first, if any."""
        order = sorted(self.tasks, key=lambda state: state.name != current_task)  # stable: otherwise task order
        for state in order:
            seed = self._next_seed(state)
            if seed is not None:
                state.running.add(seed)
                return Job(state.task, state.name, seed)
        return None

    def _next_seed(self, state: _TaskState) -> int | None:
        if not state.adaptive:
            return state.todo.popleft() if state.todo else None
        if state.stopped:
            return None
        limit = max(self.always, state.prefix + self.workers)  # hand out at most one seed per worker ahead
        for index in range(state.prefix, min(limit, len(state.seeds))):
            seed = state.seeds[index]
            if seed not in state.known and seed not in state.running and seed not in state.held:
                return seed
        return None

    def take(self, job: Job, result: EpisodeResult) -> None:
        """A worker's result: written now, held until earlier seeds are known (adaptive), or dropped."""
        state = next(state for state in self.tasks if state.task == job.task)
        state.running.discard(job.seed)
        if not state.adaptive:
            self._write(state, job.seed, result)
        elif state.stopped:
            _drop_files(self.out_dir, result, self.config)
        elif state.seeds.index(job.seed) < self.always:  # needed whatever the earlier results are
            self._write(state, job.seed, result)
            self._advance(state)
        else:
            state.held[job.seed] = result
            self._advance(state)
        self.report_if_complete(state)

    def _write(self, state: _TaskState, seed: int, result: EpisodeResult) -> None:
        append_result(self.out_dir, result)
        state.known[seed] = result
        if not state.adaptive:
            self.bar.update(1)

    def _advance(self, state: _TaskState) -> None:
        """Adaptive: walk the seeds in order over the known results, as the sequential runner does."""
        from robolab_ms.eval.runner import adaptive_sampling_done

        while not state.stopped:
            if adaptive_sampling_done(state.successes, state.prefix, len(state.seeds), self.config.ci_width):
                state.stopped = True
                self.bar.total -= len(state.seeds) - state.prefix
                self.bar.refresh()
                for held in state.held.values():
                    _drop_files(self.out_dir, held, self.config)
                state.held.clear()
                break
            seed = state.seeds[state.prefix]
            if seed in state.held:
                self._write(state, seed, state.held.pop(seed))
            if seed not in state.known:
                break
            state.successes += int(state.known[seed].success)
            state.prefix += 1
            self.bar.update(1)

    def complete(self, state: _TaskState) -> bool:
        if state.running:
            return False
        if state.adaptive:
            return state.stopped
        return not state.todo

    def report_if_complete(self, state: _TaskState) -> None:
        """Call on_task_complete once, when all of the task's results are in."""
        if not state.reported and self.complete(state):
            state.reported = True
            self.on_task_complete(state)

    def on_task_complete(self, state: _TaskState) -> None:
        """Called once per task when all its results are in (the tables are written then)."""

    def finished(self) -> bool:
        return all(self.complete(state) for state in self.tasks)


def _drop_files(out_dir: Path, result: EpisodeResult, config: EvalConfig) -> None:
    """Remove the files of an episode whose result is not kept (a seed past the adaptive stopping point)."""
    paths = []
    if result.recording:
        paths += [out_dir / result.recording, (out_dir / result.recording).with_suffix(".json")]
    if result.video:
        paths.append(out_dir / result.video)
    if config.save_actions:
        from robolab_ms.policies.replay import actions_file

        paths.append(
            actions_file(out_dir, result.policy, result.task, result.instruction_variant, result.robot, result.seed)
        )
    for path in paths:
        path.unlink(missing_ok=True)
