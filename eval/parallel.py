"""Episodes in parallel: worker processes on this machine (`robolab eval --workers N`) or Ray actors on a cluster
(`robolab eval --ray ADDRESS`), all streaming into one results folder.

Only this (the parent) process writes `episodes.jsonl`: workers send each finished episode back (over a pipe, or
as a Ray result) and the parent appends its line with `append_result`, which holds an exclusive lock and fsyncs.
So whatever is killed when, the file has no interleaved line; a parent killed mid-write leaves at most a partial
last line, which readers skip; an episode whose line was not written is run again by the rerun (its recording is
then rewritten with the same content: an episode is a pure function of its tuple, see ARCHITECTURE.md). On Linux
a worker process is killed with its parent (PR_SET_PDEATHSIG), so no orphan outlives a killed run; Ray kills a
dead driver's actors itself.

Each worker (process or actor) connects its own policy instance and keeps one environment, rebuilt only when it
moves to another task; the parent hands a worker the episodes of the task its environment holds first, so with
`--episodes` every worker builds each task's environment at most once.

Adaptive sampling (`--episodes-adaptive`) gives exactly the sequential run's episodes: seeds are handed out in
order, a little ahead of the results (at most one per worker beyond the seeds whose results are known, and the
first 10 at once); the success-rate rule is applied to the results in seed order, a result is written only once
every earlier seed's result is known and did not end the sampling, and results of seeds past the stopping point
are dropped with their files.

Ray actors write their episode files (recordings, videos, saved actions) into a scratch folder on their node and
send the bytes back with the result; the parent stores them under the results folder before appending the line.
"""

from __future__ import annotations

import os
import shutil
import signal
import sys
import tempfile
import threading
import time
import traceback
from collections import deque
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

from robolab_ms.errors import RoboLabError, make_folder
from robolab_ms.eval.results import EpisodeResult, append_result, episode_key, read_results
from robolab_ms.policies import PolicyUnavailableError

if TYPE_CHECKING:
    from robolab_ms.eval.runner import EvalConfig
    from robolab_ms.policies import Policy, PolicyOptions

LOCAL_RAY = "local"  # --ray local: start a Ray instance on this machine for this run
RAY_ACTOR_CPUS = 1  # CPUs Ray reserves for each episode actor
VIDEO_WAIT_SECONDS = 600.0  # longest wait of a Ray actor for its episode's video to be encoded


@dataclass(frozen=True)
class PolicySpec:
    """How a worker makes its own instance of the policy: `make_policy(name, options)`."""

    name: str
    options: PolicyOptions


@dataclass(frozen=True)
class Job:
    """One episode to run: the task as given to --task (a name or a task file), its name, and the seed."""

    task: str
    name: str
    seed: int


# ------------------------------------------------------------------------------------------------ worker side
class EpisodeWorker:
    """Runs episodes in one process: its own policy instance and one environment, rebuilt only for another task."""

    def __init__(self, policy: PolicySpec, config: EvalConfig, out_dir: Path, content_roots: list[str]) -> None:
        from robolab_ms.content import add_content_root
        from robolab_ms.policies import make_policy

        for root in content_roots:
            add_content_root(root)
        import robolab_ms.envs
        from robolab_ms.tasks.spec import is_task_file

        for task in config.tasks:  # task files given by path: registered in this process as the CLI did in its own
            if is_task_file(task):
                robolab_ms.envs.register_task_file(task, replace=True)
        self.config, self.out_dir = config, Path(out_dir)
        self.policy = make_policy(policy.name, policy.options)
        self.policy.connect()
        self.env: Any = None
        self.env_task: str | None = None
        self.recorder: Any = None
        self.specs: dict[str, Any] = {}
        self.bar = tqdm(disable=True)

    def run(self, job: Job) -> EpisodeResult:
        """Run one episode (an exception inside the episode is recorded in its result, as the runner does)."""
        import gymnasium as gym

        from robolab_ms.eval.recording import EpisodeRecorder
        from robolab_ms.eval.runner import _reconnect, _run_episode, env_kwargs
        from robolab_ms.tasks.spec import load_task

        spec = self.specs.get(job.task) or self.specs.setdefault(job.task, load_task(job.task))
        if self.policy.needs_reconnect:
            _reconnect(self.policy, self.config.reconnect_seconds, self.out_dir)
        if self.env_task != spec.name:
            self._close_env()
            self.env = gym.make(spec.env_id, **env_kwargs(self.policy, self.config))
            self.env_task = spec.name
            self.recorder = EpisodeRecorder(self.env, self.out_dir, self.config.record, self.policy.name)
        return _run_episode(self.env, self.policy, spec, self.config, job.seed, self.bar, self.recorder, self.out_dir)

    def wait_for_video(self, result: EpisodeResult) -> None:
        """Block until the episode's video file is complete (it is encoded on a background thread)."""
        if result.video is None or self.recorder is None or self.recorder.video is None:
            return
        path = self.out_dir / result.video
        deadline = time.monotonic() + VIDEO_WAIT_SECONDS
        while path not in self.recorder.video.written and not path.exists():
            self.recorder.video._check()  # raises the encoder's error, if it had one
            if time.monotonic() > deadline:
                raise RoboLabError(f"the video {path} was not finished after {VIDEO_WAIT_SECONDS:g} s")
            time.sleep(0.02)

    def _close_env(self) -> None:
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None
        if self.env is not None:
            self.env.close()
            self.env = None
        self.env_task = None

    def close(self) -> None:
        try:
            self._close_env()
        finally:
            self.policy.close()


def _fatal(exc: BaseException) -> tuple:
    """A worker's report of an error that stops the run: ("fatal", type name, message, is a RoboLabError)."""
    return ("fatal", type(exc).__name__, str(exc), isinstance(exc, RoboLabError))


def _die_with_parent(parent_pid: int) -> None:
    """End this process when the parent dies, even by SIGKILL (Linux: PR_SET_PDEATHSIG; elsewhere a watcher)."""
    if sys.platform.startswith("linux"):
        import ctypes

        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)
    else:

        def watch() -> None:
            while os.getppid() == parent_pid:
                time.sleep(0.5)
            os._exit(1)

        threading.Thread(target=watch, name="robolab-parent-watch", daemon=True).start()
    if os.getppid() != parent_pid:  # the parent died before the signal was set up
        os._exit(1)


def _exit_on_sigterm(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


def _worker_main(conn: Any, policy: PolicySpec | None, config: EvalConfig, out_dir: str, content_roots: list[str],
                 parent_pid: int, threads: int, worker_class: type = EpisodeWorker) -> None:  # fmt: skip
    """A worker process: receive jobs, send ("result", result) or ("fatal", ...) back, until None arrives.
    `worker_class` runs the jobs: EpisodeWorker, or another class made and used the same way (`robolab validate`'s)."""
    _die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group; the parent stops the workers
    import torch

    torch.set_num_threads(threads)
    worker = None
    try:
        worker = worker_class(policy, config, Path(out_dir), content_roots)
        signal.signal(signal.SIGTERM, _exit_on_sigterm)  # the parent's stop: leave through `finally`, cleaning up
        while True:
            job = conn.recv()
            if job is None:
                break
            conn.send(("result", worker.run(job), None))
    except (EOFError, SystemExit):  # the parent is gone, or stops this worker
        pass
    except BaseException as exc:
        if not isinstance(exc, RoboLabError):
            traceback.print_exc()
        try:
            conn.send(_fatal(exc))
        except OSError:
            pass
    finally:
        if worker is not None:
            worker.close()


class _RayEpisodeActor:
    """A Ray actor around an EpisodeWorker whose files go to a scratch folder and travel back with each result."""

    def __init__(self, policy: PolicySpec, config: EvalConfig, content_roots: list[str]) -> None:
        self.args = (policy, config, content_roots)
        self.scratch = Path(tempfile.mkdtemp(prefix="robolab-ray-"))
        self.worker: EpisodeWorker | None = None

    def run(self, job: Job) -> tuple:
        try:
            if self.worker is None:
                policy, config, roots = self.args
                self.worker = EpisodeWorker(policy, config, self.scratch, roots)
            result = self.worker.run(job)
            self.worker.wait_for_video(result)
            return ("result", result, self._take_files())
        except Exception as exc:
            if not isinstance(exc, RoboLabError):
                traceback.print_exc()
            return _fatal(exc)

    def _take_files(self) -> dict[str, bytes]:
        """Every finished file the episode left in the scratch folder, by path relative to it; removed here."""
        files = {}
        for path in sorted(self.scratch.rglob("*")):
            if path.is_file() and ".partial" not in path.name:
                files[path.relative_to(self.scratch).as_posix()] = path.read_bytes()
                path.unlink()
        return files

    def close(self) -> None:
        try:
            if self.worker is not None:
                self.worker.close()
        finally:
            shutil.rmtree(self.scratch, ignore_errors=True)


# ------------------------------------------------------------------------------------------------ parent side
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

    def __init__(self, config: EvalConfig, specs: list[Any], policy_name: str, out_dir: Path, workers: int,
                 bar: tqdm) -> None:  # fmt: skip
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
        self._report_if_complete(state)

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

    def _report_if_complete(self, state: _TaskState) -> None:
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

        paths.append(actions_file(out_dir, result.policy, result.task, result.instruction_variant, result.robot,
                                  result.seed))  # fmt: skip
    for path in paths:
        path.unlink(missing_ok=True)


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


def _raise_fatal(message: tuple, where: str, out_dir: Path) -> None:
    _, kind, text, robolab_error = message
    if kind == PolicyUnavailableError.__name__:
        raise PolicyUnavailableError(text)
    if robolab_error:
        raise RoboLabError(text)
    raise RoboLabError(f"{where} stopped with {kind}: {text} (traceback above). Finished episodes are kept in "
                       f"{out_dir}; rerun the same command to resume")  # fmt: skip


class _ProcessPool:
    """N worker processes on this machine, started with `spawn` (a fresh interpreter each), one pipe each; each
    runs its jobs with a `worker_class(policy, config, out_dir, content_roots)` (EpisodeWorker: eval's episodes)."""

    def __init__(self, count: int, policy: PolicySpec | None, config: EvalConfig, out_dir: Path,
                 worker_class: type = EpisodeWorker) -> None:  # fmt: skip
        import multiprocessing

        from robolab_ms.content import user_content_roots

        context = multiprocessing.get_context("spawn")
        roots = [str(root) for root in user_content_roots()]
        threads = max(1, (os.cpu_count() or 1) // count)
        self.out_dir = out_dir
        self.processes, self.connections = [], []
        saved = os.environ.get("OMP_NUM_THREADS")
        if saved is None:  # OpenMP / BLAS threads per worker, as Ray gives its actors (a worker imports numpy first)
            os.environ["OMP_NUM_THREADS"] = str(threads)
        try:
            self._start(count, context, policy, config, out_dir, roots, threads, worker_class)
        finally:
            if saved is None:
                os.environ.pop("OMP_NUM_THREADS", None)
        self.size = count

    def _start(self, count: int, context: Any, policy: PolicySpec | None, config: EvalConfig, out_dir: Path,
               roots: list[str], threads: int, worker_class: type) -> None:  # fmt: skip
        for index in range(count):
            parent_end, child_end = context.Pipe()
            process = context.Process(target=_worker_main, name=f"robolab-worker-{index}", daemon=True,
                                      args=(child_end, policy, config, str(out_dir), roots, os.getpid(), threads,
                                            worker_class))  # fmt: skip
            process.start()
            child_end.close()
            self.processes.append(process)
            self.connections.append(parent_end)

    def submit(self, index: int, job: Job) -> None:
        self.connections[index].send(job)

    def wait(self, busy: dict[int, Job]) -> list[tuple[int, EpisodeResult, dict | None]]:
        """Results of the busy workers that have finished (blocks until there is at least one)."""
        from multiprocessing.connection import wait

        watched = {self.connections[i]: i for i in busy} | {self.processes[i].sentinel: i for i in busy}
        finished = []
        for ready in wait(list(watched)):
            index = watched[ready]
            if ready is not self.connections[index] or any(index == done[0] for done in finished):
                continue
            try:
                message = self.connections[index].recv()
            except (EOFError, OSError):
                message = None
            if message is None or message[0] == "fatal":
                self._stopped(index, busy[index], message)
            finished.append((index, message[1], message[2]))
        for ready in watched:  # a worker that died without a word (killed, crashed in native code)
            index = watched[ready]
            if ready is self.processes[index].sentinel and not self.processes[index].is_alive():
                if not any(index == done[0] for done in finished) and not self.connections[index].poll():
                    self._stopped(index, busy[index], None)
        return finished

    def _stopped(self, index: int, job: Job, message: tuple | None) -> None:
        if message is not None:
            _raise_fatal(message, f"worker {index}", self.out_dir)
        process = self.processes[index]
        process.join(timeout=5)
        raise RoboLabError(f"worker {index} (pid {process.pid}) ended with exit code {process.exitcode} while running "
                           f"{job.name} seed {job.seed}. Finished episodes are kept in {self.out_dir}; rerun the same "
                           "command to resume")  # fmt: skip

    def close(self, graceful: bool) -> None:
        if graceful:
            for connection in self.connections:
                try:
                    connection.send(None)
                except OSError:
                    pass
            deadline = time.monotonic() + 120
            for process in self.processes:
                process.join(timeout=max(0.0, deadline - time.monotonic()))
        for process in self.processes:
            if process.is_alive():
                process.terminate()
        for process in self.processes:
            process.join(timeout=10)
            if process.is_alive():
                process.kill()
                process.join()
        for connection in self.connections:
            connection.close()


def _loopback(address: str) -> bool:
    """Whether a --ray value means this machine only: `local`, or a cluster address on the loopback interface."""
    if address == LOCAL_RAY:
        return True
    host = address.removeprefix("ray://").rsplit(":", 1)[0].strip("[]")
    return host in ("127.0.0.1", "localhost", "::1")


def _unreachable(address: str, seconds: float = 5.0) -> str | None:
    """Why nothing listens at a --ray HOST:PORT address (None when something does, or the address is `auto` or
    has no port): Ray itself keeps retrying an address where no cluster runs for minutes."""
    import socket

    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        return None
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=seconds):
            return None
    except OSError as error:
        return error.strerror or str(error) or type(error).__name__


class _RayPool:
    """N Ray actors, each with its own policy and environment, on whatever nodes Ray places them."""

    def __init__(self, address: str, count: int | None, policy: PolicySpec, config: EvalConfig, out_dir: Path) -> None:
        if _loopback(address) and "ray" not in sys.modules:
            # a single machine: Ray's processes talk over 127.0.0.1 (Ray's own switch; read when ray is imported)
            os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
        try:
            import ray
        except ImportError:
            raise RoboLabError("--ray needs the ray package: pip install 'robolab-ms[ray]' (or ray itself)") from None
        self.ray, self.out_dir = ray, out_dir
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
        self.owns_connection = not ray.is_initialized()
        if self.owns_connection:
            import logging

            options: dict[str, Any] = {"logging_level": logging.WARNING, "configure_logging": True}
            if address == LOCAL_RAY:
                options.update(num_cpus=count or os.cpu_count(), include_dashboard=False)
            else:
                options["address"] = address
                problem = _unreachable(address)
                if problem:
                    raise RoboLabError(f"--ray {address}: no Ray cluster answers there ({problem}); start one with "
                                       "`ray start --head` or use --ray local")  # fmt: skip
            try:
                ray.init(**options)
            except (ConnectionError, ValueError, RuntimeError) as exc:
                raise RoboLabError(f"--ray {address}: cannot reach a Ray cluster there ({exc}); start one with "
                                   "`ray start --head` or use --ray local") from None  # fmt: skip
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.size = count or max(1, cpus // RAY_ACTOR_CPUS)
        from robolab_ms.content import user_content_roots

        roots = [str(root) for root in user_content_roots()]
        actor = ray.remote(num_cpus=RAY_ACTOR_CPUS)(_RayEpisodeActor)
        self.actors = [actor.remote(policy, config, roots) for _ in range(self.size)]
        self.pending: dict[Any, int] = {}

    def submit(self, index: int, job: Job) -> None:
        self.pending[self.actors[index].run.remote(job)] = index

    def wait(self, busy: dict[int, Job]) -> list[tuple[int, EpisodeResult, dict | None]]:
        ready, _ = self.ray.wait(list(self.pending), num_returns=1)
        finished = []
        for ref in ready:
            index = self.pending.pop(ref)
            try:
                message = self.ray.get(ref)
            except self.ray.exceptions.RayError as exc:
                job = busy[index]
                raise RoboLabError(f"Ray actor {index} failed while running {job.name} seed {job.seed}: {exc}. "
                                   f"Finished episodes are kept in {self.out_dir}; rerun the same command to "
                                   "resume") from None  # fmt: skip
            if message[0] == "fatal":
                _raise_fatal(message, f"Ray actor {index}", self.out_dir)
            finished.append((index, message[1], message[2]))
        return finished

    def close(self, graceful: bool) -> None:
        ray = self.ray
        try:
            if graceful:
                ray.get([actor.close.remote() for actor in self.actors], timeout=120)
        except Exception:
            pass
        for actor in self.actors:
            try:
                ray.kill(actor)
            except Exception:
                pass
        if self.owns_connection:
            ray.shutdown()


def run_parallel(policy: Policy, policy_spec: PolicySpec, config: EvalConfig, out_dir: Path,
                 workers: int | None = None, ray: str | None = None,
                 show_progress: bool = True) -> list[EpisodeResult]:  # fmt: skip
    """Run every missing episode on `workers` processes (or Ray actors when `ray` names a cluster, `auto`, or
    `local`) and append their results to `out_dir`; returns all results of this policy in `out_dir`.

    The same episodes and results as `run_evaluation`, in another order in `episodes.jsonl`."""
    from robolab_ms.agents.bindings import DEFAULT_ROBOT
    from robolab_ms.eval.runner import _check_same_variations, _write_manifest, _write_tables
    from robolab_ms.eval.results import exclusive_writer
    from robolab_ms.tasks.spec import load_task

    if workers is not None and workers < 1:
        raise RoboLabError(f"--workers must be at least 1, got {workers}")
    config = replace(config, robot=config.robot or DEFAULT_ROBOT)
    out_dir = make_folder(out_dir, "--out")
    specs = [load_task(task) for task in config.tasks]  # check every task before starting any worker
    with exclusive_writer(out_dir):
        _check_same_variations(read_results(out_dir), policy, config, out_dir)
        _write_manifest(out_dir, policy, config)
        bar = tqdm(total=len(specs) * config.episodes_at_most, desc=f"eval {policy.name}", unit="episode",
                   disable=not show_progress, dynamic_ncols=True)  # fmt: skip
        pool: _ProcessPool | _RayPool | None = None
        graceful = False
        try:
            if ray:
                pool = _RayPool(ray, workers, policy_spec, config, out_dir)
            else:
                pool = _ProcessPool(workers or 1, policy_spec, config, out_dir)
            schedule = Schedule(config, specs, policy.name, out_dir, pool.size, bar)
            schedule.on_task_complete = lambda state: _write_tables(out_dir, policy)  # type: ignore[method-assign]
            for state in schedule.tasks:
                schedule._report_if_complete(state)
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
