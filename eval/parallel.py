"""Episodes in parallel: worker processes on this machine (`robolab eval --workers N`) or Ray actors on a cluster
(`robolab eval --ray ADDRESS`), all streaming into one results folder.

Only this (the parent) process writes `episodes.jsonl`: workers send each finished episode back (over a pipe, or
as a Ray result) and the parent appends its line with `append_result`, which holds an exclusive lock and fsyncs.
So whatever is killed when, the file has no interleaved line; a parent killed mid-write leaves at most a partial
last line, which readers skip; an episode whose line was not written is run again by the rerun (its recording is
then rewritten with the same content: an episode is a pure function of its tuple, see ARCHITECTURE.md).

The parts: `.schedule` (who runs which episode, which results are written), `.workers` (what runs in a worker),
`.process_pool` (processes on this machine), `.ray_pool` (Ray actors).
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from tqdm import tqdm

from robolab_ms.errors import RoboLabError, make_folder
from robolab_ms.eval.process_pool import ProcessPool
from robolab_ms.eval.ray_pool import RayPool
from robolab_ms.eval.results import EpisodeResult, read_results
from robolab_ms.eval.schedule import Job, Schedule
from robolab_ms.eval.workers import PolicySpec

if TYPE_CHECKING:
    from robolab_ms.eval.runner import EvalConfig
    from robolab_ms.policies import Policy

__all__ = ["PolicySpec", "run_parallel"]


def _store_files(out_dir: Path, files: dict[str, bytes]) -> None:
    """Write files sent back by a remote worker under the results folder (each complete or not at all)."""
    root = out_dir.resolve()
    for relative, data in files.items():
        target = (out_dir / relative).resolve()
        if root not in target.parents:
            raise RoboLabError(f"a worker sent back the file '{relative}', which is outside the results folder")
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_name(target.name + ".partial")
        partial.write_bytes(data)
        os.replace(partial, target)


def run_parallel(
    policy: Policy,
    policy_spec: PolicySpec,
    config: EvalConfig,
    out_dir: Path,
    workers: int | None = None,
    ray: str | None = None,
    show_progress: bool = True,
) -> list[EpisodeResult]:
    """Run every missing episode on `workers` processes (or Ray actors when `ray` names a cluster, `auto`, or
    `local`) and append their results to `out_dir`; returns all results of this policy in `out_dir`.

    The same episodes and results as `run_evaluation`, in another order in `episodes.jsonl`."""
    from robolab_ms.agents.bindings import DEFAULT_ROBOT
    from robolab_ms.eval.results import exclusive_writer
    from robolab_ms.eval.runner import _check_same_variations, _write_manifest, _write_tables
    from robolab_ms.tasks.spec import load_task

    if workers is not None and workers < 1:
        raise RoboLabError(f"--workers must be at least 1, got {workers}")
    config = replace(config, robot=config.robot or DEFAULT_ROBOT)
    out_dir = make_folder(out_dir, "--out")
    specs = [load_task(task) for task in config.tasks]  # check every task before starting any worker
    with exclusive_writer(out_dir):
        _check_same_variations(read_results(out_dir), policy, config, out_dir)
        _write_manifest(out_dir, policy, config)
        bar = tqdm(
            total=len(specs) * config.episodes_at_most,
            desc=f"eval {policy.name}",
            unit="episode",
            disable=not show_progress,
            dynamic_ncols=True,
        )
        pool: ProcessPool | RayPool | None = None
        graceful = False
        try:
            if ray:
                pool = RayPool(ray, workers, policy_spec, config, out_dir)
            else:
                pool = ProcessPool(workers or 1, policy_spec, config, out_dir)
            schedule = Schedule(config, specs, policy.name, out_dir, pool.size, bar)
            schedule.on_task_complete = lambda state: _write_tables(out_dir, policy)  # type: ignore[method-assign]
            for state in schedule.tasks:
                schedule.report_if_complete(state)
            current: list[str | None] = [None] * pool.size
            busy: dict[int, Job] = {}
            while True:
                for index in range(pool.size):
                    if index not in busy:
                        job = schedule.next_job(current[index])
                        if job is not None:
                            pool.submit(index, job)
                            busy[index], current[index] = job, job.name
                if not busy:
                    break
                bar.set_postfix_str(", ".join(f"{job.name} {job.seed}" for job in busy.values()), refresh=False)
                for index, result, files in pool.wait(busy):
                    if files:
                        _store_files(out_dir, files)
                    schedule.take(busy.pop(index), result)
            graceful = True
        finally:
            bar.close()
            if pool is not None:
                pool.close(graceful)
    return [r for r in read_results(out_dir) if r.policy == policy.name]
