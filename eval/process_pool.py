"""Worker processes on this machine (`robolab eval --workers N`, `robolab validate --workers N`): started with
`spawn`, one pipe each. On Linux a worker process is killed with its parent (PR_SET_PDEATHSIG), so no orphan
outlives a killed run.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.results import EpisodeResult
from robolab_ms.eval.workers import EpisodeWorker, PolicySpec, fatal_report, raise_fatal

if TYPE_CHECKING:
    from robolab_ms.eval.runner import EvalConfig
    from robolab_ms.eval.schedule import Job


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


def _worker_main(
    conn: Any,
    policy: PolicySpec | None,
    config: EvalConfig,
    out_dir: str,
    content_roots: list[str],
    parent_pid: int,
    threads: int,
    worker_class: type = EpisodeWorker,
) -> None:
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
            conn.send(fatal_report(exc))
        except OSError:
            pass
    finally:
        if worker is not None:
            worker.close()


class ProcessPool:
    """N worker processes on this machine, started with `spawn` (a fresh interpreter each), one pipe each; each
    runs its jobs with a `worker_class(policy, config, out_dir, content_roots)` (EpisodeWorker: eval's episodes)."""

    def __init__(
        self,
        count: int,
        policy: PolicySpec | None,
        config: EvalConfig,
        out_dir: Path,
        worker_class: type = EpisodeWorker,
    ) -> None:
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

    def _start(
        self,
        count: int,
        context: Any,
        policy: PolicySpec | None,
        config: EvalConfig,
        out_dir: Path,
        roots: list[str],
        threads: int,
        worker_class: type,
    ) -> None:
        for index in range(count):
            parent_end, child_end = context.Pipe()
            process = context.Process(
                target=_worker_main,
                name=f"robolab-worker-{index}",
                daemon=True,
                args=(child_end, policy, config, str(out_dir), roots, os.getpid(), threads, worker_class),
            )
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
            raise_fatal(message, f"worker {index}", self.out_dir)
        process = self.processes[index]
        process.join(timeout=5)
        raise RoboLabError(
            f"worker {index} (pid {process.pid}) ended with exit code {process.exitcode} while running "
            f"{job.name} seed {job.seed}. Finished episodes are kept in {self.out_dir}; rerun the same "
            "command to resume"
        )

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
