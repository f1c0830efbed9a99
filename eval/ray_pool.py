"""Ray actors on a cluster (`robolab eval --ray ADDRESS`), each with its own policy and environment. Ray actors
write their episode files (recordings, videos, saved actions) into a scratch folder on their node and send the bytes
back with the result; the parent stores them under the results folder before appending the line. Ray kills a dead
driver's actors itself.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.results import EpisodeResult
from robolab_ms.eval.workers import EpisodeWorker, PolicySpec, fatal_report, raise_fatal

if TYPE_CHECKING:
    from robolab_ms.eval.runner import EvalConfig
    from robolab_ms.eval.schedule import Job

LOCAL_RAY = "local"  # --ray local: start a Ray instance on this machine for this run
RAY_ACTOR_CPUS = 1  # CPUs Ray reserves for each episode actor


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
            return fatal_report(exc)

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


def _loopback(address: str) -> bool:
    """Whether a --ray value means this machine only: `local`, or a cluster address on the loopback interface."""
    if address == LOCAL_RAY:
        return True
    host = address.removeprefix("ray://").rsplit(":", 1)[0].strip("[]")
    return host in ("127.0.0.1", "localhost", "::1")


class RayPool:
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
                    raise RoboLabError(
                        f"--ray {address}: no Ray cluster answers there ({problem}); start one with "
                        "`ray start --head` or use --ray local"
                    )
            try:
                ray.init(**options)
            except (ConnectionError, ValueError, RuntimeError) as exc:
                raise RoboLabError(
                    f"--ray {address}: cannot reach a Ray cluster there ({exc}); start one with "
                    "`ray start --head` or use --ray local"
                ) from None
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
                raise RoboLabError(
                    f"Ray actor {index} failed while running {job.name} seed {job.seed}: {exc}. "
                    f"Finished episodes are kept in {self.out_dir}; rerun the same command to "
                    "resume"
                ) from None
            if message[0] == "fatal":
                raise_fatal(message, f"Ray actor {index}", self.out_dir)
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
