"""What runs inside one worker of a parallel run (a process of `robolab eval --workers N` or a Ray actor of
`--ray`): an `EpisodeWorker` with its own policy instance and one environment, rebuilt only when it moves to another
task, and the report a worker sends back when an error stops the run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tqdm import tqdm

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.results import EpisodeResult
from robolab_ms.policies import PolicyUnavailableError

if TYPE_CHECKING:
    from robolab_ms.eval.runner import EvalConfig
    from robolab_ms.eval.schedule import Job
    from robolab_ms.policies import PolicyOptions

VIDEO_WAIT_SECONDS = 600.0  # longest wait of a Ray actor for its episode's video to be encoded


@dataclass(frozen=True)
class PolicySpec:
    """How a worker makes its own instance of the policy: `make_policy(name, options)`."""

    name: str
    options: PolicyOptions


class EpisodeWorker:
    """Runs episodes in one process: its own policy instance and one environment, rebuilt only for another task
    (or one its caller lends it with `use_env`)."""

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
        self.owns_env = True  # False while running in an environment lent by the caller (use_env)
        self.recorder: Any = None
        self.specs: dict[str, Any] = {}
        self.bar = tqdm(disable=True)

    def run(self, job: Job) -> EpisodeResult:
        """Run one episode (an exception inside the episode is recorded in its result, as the runner does)."""
        import gymnasium as gym

        from robolab_ms.eval.recording import EpisodeRecorder
        from robolab_ms.eval.runner import _reconnect, _run_episode, policy_env_kwargs
        from robolab_ms.tasks.spec import load_task

        spec = self.specs.get(job.task) or self.specs.setdefault(job.task, load_task(job.task))
        if self.policy.needs_reconnect:
            _reconnect(self.policy, self.config.reconnect_seconds, self.out_dir)
        if self.env_task != spec.name:
            self.close_env()
            self.env = gym.make(spec.env_id, **policy_env_kwargs(self.policy, self.config))
            self.env_task = spec.name
            self.recorder = EpisodeRecorder(self.env, self.out_dir, self.config.record, self.policy.name)
        return _run_episode(self.env, self.policy, spec, self.config, job.seed, self.bar, self.recorder, self.out_dir)

    def use_env(self, env: Any, task_name: str) -> None:
        """Run the next episodes of task `task_name` in `env`, an environment made for it by the caller, who also
        closes it (validation runs its rest check and both policies' episodes of a task in one environment)."""
        if self.env is env:
            return
        from robolab_ms.eval.recording import EpisodeRecorder

        self.close_env()
        self.env, self.env_task, self.owns_env = env, task_name, False
        self.recorder = EpisodeRecorder(env, self.out_dir, self.config.record, self.policy.name)

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

    def close_env(self) -> None:
        """Close the recorder and the environment (a lent one stays open: its lender closes it)."""
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None
        if self.env is not None and self.owns_env:
            self.env.close()
        self.env, self.env_task, self.owns_env = None, None, True

    def close(self) -> None:
        try:
            self.close_env()
        finally:
            self.policy.close()


def fatal_report(exc: BaseException) -> tuple:
    """A worker's report of an error that stops the run: ("fatal", type name, message, is a RoboLabError)."""
    return ("fatal", type(exc).__name__, str(exc), isinstance(exc, RoboLabError))


def raise_fatal(message: tuple, where: str, out_dir: Path) -> None:
    """Raise, in the parent, the error a worker reported with `fatal_report`; `where` names the worker."""
    _, kind, text, robolab_error = message
    if kind == PolicyUnavailableError.__name__:
        raise PolicyUnavailableError(text)
    if robolab_error:
        raise RoboLabError(text)
    raise RoboLabError(
        f"{where} stopped with {kind}: {text} (traceback above). Finished episodes are kept in "
        f"{out_dir}; rerun the same command to resume"
    )
