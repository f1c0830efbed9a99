"""Task validation: is a task stable at rest, not passed at reset, not passed by chance, and solvable by the oracle?

Per task over N seeds:
- stability: with the arm holding still, no object drifts more than 2 cm over 300 physics steps after reset;
- success at reset: the task must not count as solved right after reset, nor once the objects have settled with the
  arm holding still;
- random policy: its success rate (expected near 0; above 10 % the task is too easy to pass by flailing);
- oracle: its success rate (at least 90 %) and time per episode.
Episodes of both policies run as the evaluation runner runs them (its `_run_episode`, through eval's EpisodeWorker),
into OUT/episodes.jsonl, so a rerun resumes. A `ValidationWorker` runs a task's jobs (rest check, random and oracle
episodes) in one environment without observations (`validation_env`): neither policy reads them, and every reset
builds a new scene anyway. A random episode's line carries no events and no trajectory metrics: validation reads
only its success, and tracking them is a fifth of a random step. `validate_task` checks one task in this process;
`validate_parallel` (`--workers N`) hands the jobs of all tasks, those with the longest episodes first, to eval's
worker processes and alone writes the folder, with the same rows and episodes.

When the oracle fails an episode without raising (it runs out of time), `explain_failure` says why, from what an
`EpisodeWatch` saw during that episode (which target objects the fingers touched, when and how each contact ended,
and the state of the success condition on the last step) and the episode's events: never grasped, dropped while
carried, still held at the end, placed but the condition false, placed but a flag unmet, knocked off the table ...
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.errors import RoboLabError, make_folder
from robolab_ms.eval.results import EpisodeResult, append_result, episode_key
from robolab_ms.eval.runner import EvalConfig
from robolab_ms.physics import MAX_DRIFT_M, STABILITY_PHYSICS_STEPS

MAX_RANDOM_SUCCESS = 0.10
MIN_ORACLE_SUCCESS = 0.90
REPORT_CSV, REPORT_MD = "validation.csv", "validation.md"
FELL_BELOW_M = -0.05  # an object whose centre ends this far below the table top fell off the table
NOTABLE_EVENTS = ("wrong_object_grasped", "object_tipped_over", "multiple_objects_grasped")  # added to explanations


@dataclass(frozen=True)
class TaskValidation:
    """One task's validation row."""

    task: str
    seeds: int
    max_drift_cm: float
    success_at_reset: int
    random_success: float
    oracle_success: float
    oracle_seconds: float
    oracle_errors: str
    oracle_failures: str  # why the oracle's failed episodes that raised nothing failed, grouped by explanation
    passed: bool
    problems: str


def validation_env(task_file: str, config: EvalConfig) -> Any:
    """The environment one task is validated in: its rest check and its random and oracle episodes run in it one
    after another (each starts with a reset, which builds a new scene, so each runs as in an environment of its own).
    Neither policy reads observations (the oracle reads the simulator), so none are built."""
    import gymnasium as gym

    from robolab_ms.envs import register_task_file
    from robolab_ms.eval.runner import env_kwargs

    kwargs = env_kwargs(needs_images=False, config=config, reads_observations=False)
    return gym.make(register_task_file(task_file), task=str(task_file), **kwargs)


def check_rest(task: str, seeds: range, variations: str | None = None) -> tuple[float, int]:
    """Largest object drift (m) over 300 physics steps with the arm holding still, and how many seeds count as
    solved right after reset or once the objects have settled with the arm holding still. `task`: a name or a task
    file; `variations`: domain randomization settings."""
    from robolab_ms.tasks.spec import load_task

    spec = load_task(task)
    env = validation_env(str(spec.file), validation_config((str(spec.file),), len(seeds), seeds.start, variations))
    try:
        return rest_check(env, seeds)
    finally:
        env.close()


def rest_check(env: Any, seeds: range) -> tuple[float, int]:
    """`check_rest` in a validation environment of the task (`validation_env`)."""
    base = env.unwrapped
    worst, solved = 0.0, 0
    for seed in seeds:
        _, info = env.reset(seed=seed)
        solved_now = bool(info["success"][0])
        solved += solved_now
        start = {name: actor.pose.p[0].clone() for name, actor in base.objects.items()}
        hold = np.concatenate([base.arm_qpos()[0].numpy(), [0.0]]).astype(np.float32)
        for _ in range(-(-STABILITY_PHYSICS_STEPS // (base.sim_freq // base.control_freq))):
            _, _, _, _, info = env.step(hold)
        # Objects start a few mm above their support: a condition that needs contact holds only once they settle.
        solved += bool(info["success"][0]) and not solved_now
        for name, actor in base.objects.items():
            worst = max(worst, float((actor.pose.p[0] - start[name]).norm()))
    return worst, solved


# ------------------------------------------------------------------------------------------------ watching the oracle
@dataclass
class ContactEnd:
    """The fingers stopped touching a target object: at which step, whether the gripper was then commanded closed
    (it slipped out: dropped) or open (let go: released), and how high its centre was above the table top (m)."""

    step: int
    obj: str
    gripper_closed: bool
    height: float


@dataclass
class FinalState:
    """The success conditions on an episode's last step, per target object."""

    holds: list[dict[str, bool]]  # per success condition: does it hold for each of its objects
    placed: list[dict[str, bool]]  # ... with require_contact_with / require_gripper_detached left out
    held: list[str]  # target objects the fingers touch
    heights: dict[str, float]  # centre height above the table top (m)


@dataclass
class EpisodeWatch:
    """What validation saw of one episode."""

    seed: int
    touched: set[str] = field(default_factory=set)
    contact_ends: list[ContactEnd] = field(default_factory=list)
    final: FinalState | None = None


class WatchedPolicy:
    """A privileged policy (the oracle) that also records, per episode, what `explain_failure` needs. Everything
    else is the wrapped policy's: its name, so results are filed as usual, and every attribute not defined here."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self.name, self.needs_images, self.privileged = policy.name, policy.needs_images, True
        self.reads_observations = False  # the oracle plans from the simulator it is bound to (`validation_env`)
        self.watches: dict[int, EpisodeWatch] = {}
        self.env: Any = None

    def __getattr__(self, name: str) -> Any:
        if name == "policy":  # not set yet (e.g. while unpickling)
            raise AttributeError(name)
        return getattr(self.policy, name)

    def bind(self, env: Any) -> None:
        self.env = env.unwrapped
        self.policy.bind(env)

    def reset(self, instruction: str, action_space: Any, seed: int) -> None:
        self.watch = self.watches[seed] = EpisodeWatch(seed)
        self._touching: set[str] = set()
        self._gripper_closed = False
        self.policy.reset(instruction, action_space, seed)

    def act(self, observation: Any) -> np.ndarray:
        action = self.policy.act(observation)
        self._look(int(self.env.elapsed_steps[0]))
        self._gripper_closed = bool(np.asarray(action)[-1] > 0.5)
        return action

    def _look(self, step: int) -> None:
        from robolab_ms.tasks.predicates import CONTACT_FORCE_N

        env, watch = self.env, self.watch
        context, targets = env.eval_context, condition_objects(env.task_spec)
        forces = context.gripper_forces(targets)[0]
        touching = {name for name, force in zip(targets, forces.tolist()) if force > CONTACT_FORCE_N}
        for name in sorted(self._touching - touching):
            height = float(context.centre(name)[0, 2])
            watch.contact_ends.append(ContactEnd(step, name, self._gripper_closed, round(height, 3)))
        watch.touched |= touching
        self._touching = touching
        if step >= env.task_spec.max_episode_steps - 1:  # the last step of an episode that did not succeed
            watch.final = final_state(env, touching, targets)


def condition_objects(spec: Any) -> list[str]:
    """The objects the task's success conditions are about, in order of appearance."""
    names: list[str] = []
    for condition in spec.success:
        names += [name for name in condition.objects if name not in names]
    return names


def final_state(env: Any, held: set[str], targets: list[str]) -> FinalState:
    """The success conditions now, per object, with and without their flags."""
    from robolab_ms.tasks.predicates import per_object

    context = env.eval_context
    holds, placed = [], []
    for condition in env.task_spec.success:
        relaxed = replace(condition, require_contact_with=False, require_gripper_detached=False)
        holds.append(dict(zip(condition.objects, per_object(context, condition)[0].tolist())))
        placed.append(dict(zip(condition.objects, per_object(context, relaxed)[0].tolist())))
    heights = {name: round(float(context.centre(name)[0, 2]), 3) for name in targets}
    return FinalState(holds, placed, sorted(held), heights)


# ------------------------------------------------------------------------------------------------ explaining
def describe(condition: Any) -> str:
    """A condition in one short line, e.g. `in_container(banana, container=bowl)`."""
    arguments = [", ".join(condition.objects), *(f"{key}={value}" for key, value in condition.references.items())]
    return f"{condition.predicate}({', '.join(arguments)})"


def _contact_flag(condition: Any) -> str:
    """What require_contact_with asks, for an object that is placed and let go of but does not count."""
    if condition.require_contact_with:
        return f"not touching {next(iter(condition.references.values()), 'its reference')} (require_contact_with)"
    return "its flags unmet"


def explain_failure(result: EpisodeResult, watch: EpisodeWatch | None, spec: Any) -> str:
    """Why an episode did not succeed, in one line, for an author deciding whether to blame the object, the scene
    or the planner. An error is its own explanation; without a watch (an episode resumed from an earlier run) only
    the events can speak."""
    if result.error:
        return result.error
    events = result.events
    if watch is None or watch.final is None:
        return "no success in %d steps; events: %s" % (result.steps, _event_summary(events) or "none")
    final = watch.final
    index = max(range(len(spec.success)), key=lambda i: sum(final.holds[i].values()))  # the closest condition
    condition = spec.success[index]
    holds, placed = final.holds[index], final.placed[index]
    ends = defaultdict(list)
    for end in watch.contact_ends:
        ends[end.obj].append(end)
    out_of_scene = {event["object"] for event in events if event["type"] == "object_out_of_scene"}
    findings = []
    for name in condition.objects:
        if holds[name]:
            continue
        if name in out_of_scene or final.heights[name] < FELL_BELOW_M:
            findings.append(f"{name} fell off the table")
        elif name not in watch.touched:
            findings.append(f"{name} never grasped (the fingers never touched it)")
        elif name in final.held:
            extra = (
                "; the placement is right, but require_gripper_detached needs it let go of"
                if placed[name] and condition.require_gripper_detached
                else ""
            )
            findings.append(f"{name} still held at the end{extra}")
        elif placed[name]:
            findings.append(f"{name} placed, but {_contact_flag(condition)} at the end")
        else:
            last = ends[name][-1] if ends[name] else None
            drops = [end for end in ends[name] if end.gripper_closed]
            if last is not None and last.gripper_closed:
                findings.append(
                    f"{name} dropped at step {last.step} (slipped out of the closed gripper "
                    f"{last.height * 100:.0f} cm above the table); {describe(condition)} false at the end"
                )
            elif last is not None:
                dropped = f" after {len(drops)} drop(s)" if drops else ""
                findings.append(
                    f"{name} placed (let go at step {last.step}{dropped}) but {describe(condition)} false at the end"
                )
            else:
                findings.append(f"{name} touched but {describe(condition)} false at the end")
    if not findings:
        findings.append(f"{describe(condition)} holds for some objects but not as `{condition.logical}` needs")
    others = _event_summary([event for event in events if event["type"] in NOTABLE_EVENTS])
    notes = f" [events: {others}]" if others else ""
    return f"ran out of time ({result.steps} steps): " + "; ".join(findings) + notes


def _event_summary(events: list[dict]) -> str:
    """Events as `type object @step`, the first of each (type, object) with a count of repeats."""
    seen: dict[tuple[str, str], list[int]] = {}
    for event in events:
        seen.setdefault((event["type"], event["object"]), []).append(event["step"])
    return ", ".join(
        f"{kind} {obj} @{steps[0]}" + (f" (x{len(steps)})" if len(steps) > 1 else "")
        for (kind, obj), steps in seen.items()
    )


def group_explanations(explained: list[tuple[int, str]]) -> str:
    """`seed 3, 7: <why>; seed 5: <why>` (seeds sharing an explanation go together)."""
    by_text: dict[str, list[int]] = defaultdict(list)
    for seed, text in explained:
        by_text[text].append(seed)
    return "; ".join(f"seed {', '.join(map(str, seeds))}: {text}" for text, seeds in by_text.items())


# ------------------------------------------------------------------------------------------------ one task
def validation_config(task_files: tuple[str, ...], seeds: int, first_seed: int, variations: str | None) -> EvalConfig:
    """The evaluation settings of the random and the oracle episodes of a validation run."""
    from robolab_ms.agents import DEFAULT_ROBOT

    return EvalConfig(
        tasks=task_files, episodes=seeds, first_seed=first_seed, robot=DEFAULT_ROBOT, variations=variations
    )


def task_row(
    spec: Any, seeds: range, rest: tuple[float, int], results: list[EpisodeResult], watches: dict[int, EpisodeWatch]
) -> TaskValidation:
    """One task's row from its rest check (largest drift in m, seeds solved at reset), the random and oracle episodes
    of its seeds among `results`, and the watches of the oracle episodes run now (those resumed have none)."""
    from robolab_ms.agents import DEFAULT_ROBOT

    drift, solved_at_reset = rest
    by_key = {r.key(): r for r in results}

    def episodes(policy: str) -> list[EpisodeResult]:
        keys = (episode_key(spec.name, "default", DEFAULT_ROBOT, policy, seed) for seed in seeds)  # default instruction
        return [by_key[key] for key in keys if key in by_key]

    random_results, oracle_results = episodes("random"), episodes("oracle")
    random_rate = float(np.mean([r.success for r in random_results]))
    oracle_rate = float(np.mean([r.success for r in oracle_results]))
    errors = sorted({r.error for r in oracle_results if r.error})
    failed = [r for r in oracle_results if not r.success and not r.error]
    failures = group_explanations([(r.seed, explain_failure(r, watches.get(r.seed), spec)) for r in failed])
    problems = []
    if drift > MAX_DRIFT_M:
        problems.append(f"an object drifts {drift * 100:.1f} cm at rest (max {MAX_DRIFT_M * 100:.0f})")
    if solved_at_reset:
        problems.append(f"solved at reset in {solved_at_reset} seed(s)")
    if random_rate > MAX_RANDOM_SUCCESS:
        problems.append(f"random policy succeeds {random_rate:.0%} (max {MAX_RANDOM_SUCCESS:.0%})")
    if oracle_rate < MIN_ORACLE_SUCCESS:
        problems.append(f"oracle succeeds only {oracle_rate:.0%} (min {MIN_ORACLE_SUCCESS:.0%})")
    return TaskValidation(
        task=spec.name,
        seeds=len(seeds),
        max_drift_cm=round(drift * 100, 2),
        success_at_reset=solved_at_reset,
        random_success=round(random_rate, 3),
        oracle_success=round(oracle_rate, 3),
        oracle_seconds=round(float(np.mean([r.wall_seconds for r in oracle_results])), 2),
        oracle_errors="; ".join(errors),
        oracle_failures=failures,
        passed=not problems,
        problems="; ".join(problems),
    )


def validate_task(
    task: str, seeds: int, out_dir: Path, first_seed: int = 0, show_progress: bool = True, variations: str | None = None
) -> TaskValidation:
    """Run every check on one task (a name or a task file), under `variations` if given, in this process; episodes
    go to `out_dir` (a rerun resumes from them). The jobs and their order are those a worker of `validate_parallel`
    runs for the task, in the same kind of worker."""
    from tqdm import tqdm

    from robolab_ms.envs import register_task_file
    from robolab_ms.eval.results import exclusive_writer, read_results
    from robolab_ms.eval.runner import _check_same_variations, _write_manifest, _write_tables
    from robolab_ms.tasks.spec import load_task

    spec = load_task(task)
    register_task_file(spec.file, replace=True)  # the id loads exactly this file in this process
    seed_range = range(first_seed, first_seed + seeds)
    config = validation_config((str(spec.file),), seeds, first_seed, variations)
    out_dir = make_folder(out_dir, "--out")
    with exclusive_writer(out_dir):
        results = {r.key(): r for r in read_results(out_dir)}
        worker = ValidationWorker(None, config, out_dir, [])
        try:
            policies = worker.policies()
            for policy in policies.values():
                _check_same_variations(results.values(), policy, config, out_dir)
            _write_manifest(out_dir, policies[ORACLE], config)
            jobs, done_before = task_jobs(spec, seed_range, config, results)
            bar = tqdm(
                total=2 * seeds,
                initial=done_before,
                desc=f"validate {spec.name}",
                unit="episode",
                disable=not show_progress,
                dynamic_ncols=True,
            )
            rest: tuple[float, int] = (0.0, 0)
            watches: dict[int, EpisodeWatch] = {}
            try:
                for job in jobs:
                    bar.set_postfix_str(f"{job.check} {job.seed}", refresh=False)
                    outcome = worker.run(job)
                    if job.check == REST:
                        rest = outcome
                        continue
                    result, watch = outcome
                    append_result(out_dir, result)
                    results[result.key()] = result
                    if watch is not None:
                        watches[job.seed] = watch
                    bar.update(1)
            finally:
                bar.close()
        finally:
            worker.close()
        _write_tables(out_dir, policies[ORACLE])  # as `validate_parallel` leaves them
    return task_row(spec, seed_range, rest, list(results.values()), watches)


def task_jobs(
    spec: Any, seeds: range, config: EvalConfig, results: dict[tuple, EpisodeResult]
) -> tuple[list[ValidationJob], int]:
    """A task's validation jobs: its rest check, then its random and its oracle episodes not yet among `results`;
    and how many of its episodes are there already."""
    jobs = [ValidationJob(REST, str(spec.file), spec.name, seeds.start)]
    done = 0
    for check in (RANDOM, ORACLE):
        for seed in seeds:
            if episode_key(spec.name, config.instruction, config.robot, check, seed) in results:
                done += 1
            else:
                jobs.append(ValidationJob(check, str(spec.file), spec.name, seed))
    return jobs, done


# ------------------------------------------------------------------------------------------------ in worker processes
REST, RANDOM, ORACLE = "rest", "random", "oracle"  # the kinds of validation job


@dataclass(frozen=True)
class ValidationJob:
    """One piece of a validation run: a task's rest check (over all its seeds, `seed` the first) or one episode of
    the random or the oracle policy. `task` is the task file, `name` the task's name."""

    check: str  # REST, RANDOM or ORACLE
    task: str
    name: str
    seed: int


class ValidationWorker:
    """Runs validation jobs, in a worker process of `robolab validate --workers N` (eval's process pool) or in this
    process (`validate_task`): all the jobs of a task in one environment (`validation_env`), rebuilt when a job of
    another task comes; the rest check as `check_rest` does it, and the random and oracle episodes each through an
    eval EpisodeWorker of its own, lent that environment."""

    def __init__(self, policy: None, config: EvalConfig, out_dir: Path, content_roots: list[str]) -> None:
        """`policy` is unused (validation always runs the random and the oracle policy); the rest as EpisodeWorker."""
        from robolab_ms.eval.recording import RecordOptions
        from robolab_ms.eval.workers import EpisodeWorker, PolicySpec
        from robolab_ms.policies import PolicyOptions

        self.config = config
        # validation reads only the success of a random episode: its line carries no events and no trajectory metrics
        configs = {RANDOM: replace(config, record=RecordOptions(metrics=False)), ORACLE: config}
        self.episode_workers = {
            name: EpisodeWorker(PolicySpec(name, PolicyOptions()), configs[name], out_dir, content_roots)
            for name in (RANDOM, ORACLE)
        }
        self.episode_workers[ORACLE].policy = WatchedPolicy(self.episode_workers[ORACLE].policy)
        self.env: Any = None
        self.env_task: str | None = None

    def policies(self) -> dict[str, Any]:
        """The random policy and the watched oracle, by check."""
        return {check: worker.policy for check, worker in self.episode_workers.items()}

    def run(self, job: ValidationJob) -> tuple[float, int] | tuple[EpisodeResult, EpisodeWatch | None]:
        """A rest check's (largest drift in m, seeds solved at reset), or an episode's result with the oracle's
        watch of it (None for the random policy)."""
        from robolab_ms.eval.schedule import Job

        if self.env_task != job.task:
            self.close_env()
            self.env, self.env_task = validation_env(job.task, self.config), job.task
        self.env.unwrapped.track_events = job.check == ORACLE  # the oracle's events explain its failures
        if job.check == REST:
            return rest_check(self.env, range(job.seed, job.seed + self.config.episodes))
        worker = self.episode_workers[job.check]
        worker.use_env(self.env, job.name)
        result = worker.run(Job(job.task, job.name, job.seed))
        watch = worker.policy.watches.pop(job.seed, None) if job.check == ORACLE else None
        return result, watch

    def close_env(self) -> None:
        """Close the task's environment (and the episode workers' recorders of it)."""
        for worker in self.episode_workers.values():
            worker.close_env()
        if self.env is not None:
            self.env.close()
        self.env, self.env_task = None, None

    def close(self) -> None:
        try:
            self.close_env()
        finally:
            try:
                self.episode_workers[RANDOM].close()
            finally:
                self.episode_workers[ORACLE].close()


@dataclass
class _TaskProgress:
    """The lead process's view of one task in a parallel validation run."""

    spec: Any
    jobs_left: int  # jobs handed out or still to hand out
    rest: tuple[float, int] | None = None
    watches: dict[int, EpisodeWatch] = field(default_factory=dict)
    row: TaskValidation | None = None


def validate_parallel(
    tasks: list[str],
    seeds: int,
    out_dir: Path,
    first_seed: int = 0,
    workers: int = 2,
    show_progress: bool = True,
    variations: str | None = None,
) -> list[TaskValidation]:
    """Validate `tasks` (names or task files) with their rest checks and episodes spread over `workers` processes;
    the same rows and episodes as `validate_task` task after task. This process alone writes `out_dir`: each
    episode's line as it arrives (a rerun resumes from them) and the report whenever a task is complete (its rows
    in task order). Returns the rows in task order."""
    from tqdm import tqdm

    from robolab_ms.eval.process_pool import ProcessPool
    from robolab_ms.eval.results import exclusive_writer, read_results
    from robolab_ms.eval.runner import _check_same_variations, _write_manifest, _write_tables
    from robolab_ms.policies import make_policy
    from robolab_ms.tasks.spec import load_task

    if workers < 1:
        raise RoboLabError(f"--workers must be at least 1, got {workers}")
    specs = [load_task(task) for task in tasks]  # every task checked before any worker starts
    seed_range = range(first_seed, first_seed + seeds)
    config = validation_config(tuple(str(spec.file) for spec in specs), seeds, first_seed, variations)
    out_dir = make_folder(out_dir, "--out")
    with exclusive_writer(out_dir):
        results = {r.key(): r for r in read_results(out_dir)}
        policies = {RANDOM: make_policy(RANDOM), ORACLE: WatchedPolicy(make_policy(ORACLE))}
        for policy in policies.values():
            _check_same_variations(results.values(), policy, config, out_dir)
        _write_manifest(out_dir, policies[ORACLE], config)
        todo: list[ValidationJob] = []
        progress: dict[str, _TaskProgress] = {}  # in task order, the order of the rows
        done_before = 0
        for spec in specs:
            jobs, done = task_jobs(spec, seed_range, config, results)
            progress[spec.name] = _TaskProgress(spec, len(jobs))
            done_before += done
            todo += jobs
        # The tasks with the longest episodes first: the workers then end on short episodes, close together.
        todo.sort(key=lambda job: -progress[job.name].spec.max_episode_steps)  # stable: each task's jobs in order
        bar = tqdm(
            total=2 * seeds * len(specs),
            initial=done_before,
            desc="validate",
            unit="episode",
            disable=not show_progress,
            dynamic_ncols=True,
        )
        pool: ProcessPool | None = None
        graceful = False
        try:
            pool = ProcessPool(min(workers, len(todo)), None, config, out_dir, worker_class=ValidationWorker)
            current: list[str | None] = [None] * pool.size
            busy: dict[int, ValidationJob] = {}
            while True:
                for index in range(pool.size):
                    if index not in busy and todo:
                        job = _next_job(todo, current[index])
                        pool.submit(index, job)
                        busy[index], current[index] = job, job.name
                if not busy:
                    break
                bar.set_postfix_str(
                    ", ".join(f"{job.name} {job.check} {job.seed}" for job in busy.values()), refresh=False
                )
                for index, outcome, _ in pool.wait(busy):
                    job = busy.pop(index)
                    task = progress[job.name]
                    if job.check == REST:
                        task.rest = outcome
                    else:
                        result, watch = outcome
                        append_result(out_dir, result)
                        results[result.key()] = result
                        if watch is not None:
                            task.watches[job.seed] = watch
                        bar.update(1)
                    task.jobs_left -= 1
                    if task.jobs_left == 0:
                        task.row = task_row(task.spec, seed_range, task.rest, list(results.values()), task.watches)
                        write_report([t.row for t in progress.values() if t.row is not None], out_dir)
            graceful = True
        finally:
            bar.close()
            if pool is not None:
                pool.close(graceful)
        _write_tables(out_dir, policies[ORACLE])  # as the sequential run leaves them: its last evaluation's
    return [task.row for task in progress.values()]


def _next_job(todo: list[ValidationJob], current_task: str | None) -> ValidationJob:
    """Take the next job for a worker whose environments hold `current_task`: that task's first, if any."""
    index = next((i for i, job in enumerate(todo) if job.name == current_task), 0)
    return todo.pop(index)


def write_report(rows: list[TaskValidation], out_dir: Path) -> Path:
    """Write OUT/validation.csv and OUT/validation.md; returns the Markdown file."""
    import pandas as pd

    from robolab_ms.analysis.tables import to_markdown

    table = pd.DataFrame([asdict(row) for row in rows])
    table.to_csv(out_dir / REPORT_CSV, index=False)
    markdown = out_dir / REPORT_MD
    markdown.write_text(to_markdown(table) + "\n")
    return markdown
