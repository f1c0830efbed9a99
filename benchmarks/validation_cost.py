"""What validating a task costs, check by check: the rest check, the random policy's episodes and the oracle's, run
as `robolab validate` runs them (a ValidationWorker in this process, writing into a temporary folder).

    .venv/bin/python benchmarks/validation_cost.py [--task BananaInBowl ClutterPlastic PutMugsOnShelf] [--seeds 2]

Per task it prints each check's wall and CPU seconds, the random episodes' milliseconds per control step, and the
oracle's median seconds per episode split into its own `act` (planning and replanning) and the environment's steps.

Baseline, in the same process: the same random episodes in an environment with state observations, as validation
made them before it built none (`obs_mode="state_dict"`, what `robolab eval` gives a state policy) and with their
events and trajectory metrics, each right after its twin, so that a change of machine load hits both. The ratio
line: milliseconds per random control step in the validation environment over those in the state-observation
environment (medians over the episodes). The two must give the same episodes (events and metrics aside); the script
stops with an error if they do not.

With --oracle-baseline, each oracle episode is run a second time as the oracle planned before its two speed-ups:
its ray-cast maps cast anew at every call (`RAY_MAPS.keep` off; now kept while nothing moves) and each straight move
of a chain timed as soon as it is found (`MotionPlanner.time_each_move` on; now a chain is timed once all its moves
are found, and most chains tried are given up part of the way); the script stops with an error if the oracle's
actions differ, and prints the oracle's median wall and CPU seconds per episode both ways and the ratio of the CPU
seconds (the machine may be shared). With
--oracle-only the rest checks and the random episodes are left out.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from dataclasses import asdict, replace
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from robolab_ms.envs import register_task_file
from robolab_ms.eval.recording import EpisodeRecorder
from robolab_ms.eval.results import TIMING_FIELDS, EpisodeResult
from robolab_ms.eval.runner import EvalConfig, _run_episode, env_kwargs
from robolab_ms.eval.validate import (
    ORACLE,
    RANDOM,
    REST,
    ValidationWorker,
    task_jobs,
    validation_config,
    validation_env,
)
from robolab_ms.policies import RandomPolicy
from robolab_ms.policies.oracle.motion import MotionPlanner
from robolab_ms.policies.oracle.world import RAY_MAPS
from robolab_ms.tasks.spec import load_task

DEFAULT_TASKS = ("BananaInBowl", "ClutterPlastic", "PutMugsOnShelf")  # 2 objects; 17 objects; a rack with boards


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", nargs="+", default=list(DEFAULT_TASKS), help="tasks to validate")
    parser.add_argument("--seeds", type=int, default=2, help="seeds per task (default: 2)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    parser.add_argument(
        "--oracle-baseline",
        action="store_true",
        help="also run each oracle episode as before its speed-ups (ray-cast maps not kept, each move timed at once)",
    )
    parser.add_argument("--oracle-only", action="store_true", help="run only the oracle's episodes")
    args = parser.parse_args()
    max_steps = None
    if args.quick:
        args.task, args.seeds, max_steps = ["BananaInBowl"], 1, 3
    with tempfile.TemporaryDirectory(prefix="validation-cost-") as folder:
        measure(args.task, args.seeds, max_steps, Path(folder), args.oracle_baseline, args.oracle_only)


def timed(run) -> tuple[object, float, float]:
    """`run()`'s value with its wall and CPU seconds."""
    wall, cpu = time.perf_counter(), time.process_time()
    value = run()
    return value, time.perf_counter() - wall, time.process_time() - cpu


UNTRACKED = {"events", "event_counts", "event_objects", "metrics"}  # what validation leaves out of a random episode


def comparable(result: EpisodeResult) -> dict:
    return {key: value for key, value in asdict(result).items() if key not in TIMING_FIELDS | UNTRACKED}


def state_env(spec, config: EvalConfig):
    """An environment of the task with state observations, as `robolab eval` makes one for a state policy."""
    return gym.make(register_task_file(spec.file), task=str(spec.file), **env_kwargs(False, config))


def recording_actions(worker: ValidationWorker) -> list[np.ndarray]:
    """The list that the oracle's actions are appended to from now on, one per control step."""
    oracle = worker.episode_workers[ORACLE].policy.policy
    actions: list[np.ndarray] = []
    act = oracle.act

    def recorded(observation):
        action = act(observation)
        actions.append(np.array(action, copy=True))
        return action

    oracle.act = recorded
    return actions


def measure(
    tasks: list[str],
    seeds: int,
    max_steps: int | None,
    out: Path,
    oracle_baseline: bool = False,
    oracle_only: bool = False,
) -> None:
    specs = [load_task(task) for task in tasks]
    config = validation_config(tuple(str(spec.file) for spec in specs), seeds, 0, None)
    config = replace(config, max_steps=max_steps)
    worker = ValidationWorker(None, config, out, [])
    ours_ms, state_ms = [], []
    oracle_seconds: dict[bool, list[tuple[float, float]]] = {True: [], False: []}  # (wall, CPU): now, before
    actions = recording_actions(worker)
    print(f"seeds per task: {seeds}" + (f", at most {max_steps} steps per episode" if max_steps else ""))
    try:
        for spec in specs:
            jobs, _ = task_jobs(spec, range(seeds), config, {})
            if oracle_only:
                jobs = [job for job in jobs if job.check == ORACLE]
                worker.close_env()  # the task's environment built before the first episode is timed
                worker.env, worker.env_task = validation_env(str(spec.file), config), str(spec.file)
            seconds = {REST: [0.0, 0.0], RANDOM: [0.0, 0.0], ORACLE: [0.0, 0.0]}
            random_steps, oracle_results = 0, []
            baseline = None if oracle_only else state_env(spec, config)
            recorder = None if oracle_only else EpisodeRecorder(baseline, out, config.record, RandomPolicy.name)
            for job in jobs:
                actions.clear()
                outcome, wall, cpu = timed(lambda job=job: worker.run(job))
                kept = np.array(actions)
                seconds[job.check][0] += wall
                seconds[job.check][1] += cpu
                if job.check == RANDOM:
                    result = outcome[0]
                    random_steps += result.steps
                    ours_ms.append(result.wall_seconds / max(result.steps, 1) * 1000)
                    state = _run_episode(
                        baseline, RandomPolicy(), spec, config, job.seed, tqdm(disable=True), recorder, out
                    )
                    state_ms.append(state.wall_seconds / max(state.steps, 1) * 1000)
                    if comparable(state) != comparable(result):
                        raise SystemExit(f"{spec.name} seed {job.seed}: the state-observation episode differs")
                elif job.check == ORACLE:
                    oracle_results.append(outcome[0])
                    oracle_seconds[True].append((wall, cpu))
                    if oracle_baseline:
                        actions.clear()
                        RAY_MAPS.keep, MotionPlanner.time_each_move = False, True
                        try:
                            _, anew_wall, anew_cpu = timed(lambda job=job: worker.run(job))
                        finally:
                            RAY_MAPS.keep, MotionPlanner.time_each_move = True, False
                        oracle_seconds[False].append((anew_wall, anew_cpu))
                        if not np.array_equal(np.array(actions), kept):
                            raise SystemExit(f"{spec.name} seed {job.seed}: the oracle's actions differ")
            if baseline is not None:
                baseline.close()
            report(spec.name, seconds, random_steps, oracle_results)
    finally:
        worker.close()
    if oracle_baseline and oracle_seconds[False]:
        (kept_wall, kept_cpu), (anew_wall, anew_cpu) = (
            [statistics.median(seconds[i] for seconds in oracle_seconds[kept]) for i in (0, 1)]
            for kept in (True, False)
        )
        print(
            f"\noracle episodes (the same actions both ways), median wall s: now {kept_wall:.2f}, "
            f"before the speed-ups {anew_wall:.2f}; median CPU s: {kept_cpu:.2f}, {anew_cpu:.2f}"
        )
        print(f"ratio now / before the speed-ups (oracle episode, CPU s): {kept_cpu / anew_cpu:.3f}")
        now_total, before_total = (sum(cpu for _, cpu in oracle_seconds[kept]) for kept in (True, False))
        print(
            f"ratio now / before the speed-ups (all oracle episodes, total CPU s {now_total:.1f} / "
            f"{before_total:.1f}): {now_total / before_total:.3f}"
        )
    if not ours_ms:
        return
    ratio = statistics.median(ours_ms) / statistics.median(state_ms)
    print(
        f"\nrandom episodes, ms per control step: validation env median {statistics.median(ours_ms):.2f}, "
        f"state-observation env median {statistics.median(state_ms):.2f}"
    )
    print(f"ratio validation env / state-observation env (random steps): {ratio:.3f}")


def report(name: str, seconds: dict[str, list[float]], random_steps: int, oracle: list[EpisodeResult]) -> None:
    """One task's lines."""
    total_wall = sum(wall for wall, _ in seconds.values())
    print(f"\n{name}: {total_wall:.1f} s in all")
    for check, (wall, cpu) in seconds.items():
        print(f"  {check:7s} {wall:7.1f} s wall {cpu:7.1f} s CPU")
    if random_steps:
        print(f"  random: {seconds[RANDOM][0] / random_steps * 1000:.2f} ms per control step ({random_steps} steps)")
    if oracle:
        walls = [r.wall_seconds for r in oracle]
        planning = sum((r.inference_ms_mean or 0.0) * r.queries / 1000 for r in oracle)
        stepping = sum((r.env_step_ms or 0.0) * r.steps / 1000 for r in oracle)
        successes = sum(r.success for r in oracle)
        print(
            f"  oracle: median {statistics.median(walls):.2f} s per episode ({successes}/{len(oracle)} solved); "
            f"{planning / sum(walls):.0%} in the oracle's act, {stepping / sum(walls):.0%} in env steps"
        )


if __name__ == "__main__":
    main()
