"""What every remote policy client shares: reaching the server, action chunks executed open loop, checking replies.

A remote policy answers a query with a chunk of actions (H x 8); the client executes the first
`open_loop_horizon` of them, one per control step, before it asks again. Every fault of the server shows up as one
of the `PolicyError`s: the runner records the episode as errored with the message and goes on.
"""

from __future__ import annotations

import socket
import time
from collections import deque
from typing import Any

import numpy as np
from gymnasium import spaces

from robolab_ms.policies import (
    Policy,
    PolicyReplyError,
    PolicyUnavailableError,
)

ACTION_DIM = 8  # 7 arm joint targets + 1 gripper


def probe_server(host: str, port: int, protocol: str, start_hint: str, timeout: float = 3.0) -> None:
    """Raise PolicyUnavailableError with a one-paragraph explanation when nothing listens at host:port."""
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
    raise PolicyUnavailableError(
        f"no {protocol} policy server answers at {host}:{port} ({reason}). Start one first, for example "
        f"{start_hint}, or point --host/--port at the machine that runs it (a GPU server: check that the port is "
        "open, or forward it with `ssh -L`). Nothing was run and no episode was recorded."
    )


def check_chunk(chunk: Any, source: str, key: str = "actions", action_dim: int = ACTION_DIM) -> np.ndarray:
    """A reply's action chunk as float32 (H, action_dim), or PolicyReplyError saying what is wrong with it."""
    if not isinstance(chunk, np.ndarray):
        raise PolicyReplyError(f"{source}: '{key}' is a {type(chunk).__name__}, not an array")
    if chunk.dtype.kind not in "f":
        raise PolicyReplyError(f"{source}: '{key}' has dtype {chunk.dtype}; expected floating point (float32)")
    if chunk.ndim == 1 and chunk.shape[0] == action_dim:
        chunk = chunk[None]  # a single action
    if chunk.ndim != 2 or chunk.shape[0] < 1 or chunk.shape[1] != action_dim:
        raise PolicyReplyError(f"{source}: '{key}' has shape {chunk.shape}; expected (H, {action_dim}): H actions "
                               f"of 7 joint targets and the gripper")  # fmt: skip
    if not np.isfinite(chunk).all():
        bad = "NaN" if np.isnan(chunk).any() else "infinity"
        raise PolicyReplyError(f"{source}: '{key}' holds {bad}")
    return chunk.astype(np.float32)


class ChunkedPolicy(Policy):
    """A policy that answers in chunks: `query` returns (H, 8); the first `open_loop_horizon` actions are executed
    before the next query. Subclasses implement `query` and, for servers, `connect` and `close`."""

    def __init__(self, open_loop_horizon: int) -> None:
        if open_loop_horizon < 1:
            raise PolicyUnavailableError(f"--open-loop-horizon must be at least 1, got {open_loop_horizon}")
        self.open_loop_horizon = open_loop_horizon
        self._queue: deque[np.ndarray] = deque()
        self._query_ms: list[float] = []
        self.step = 0
        self.action_space: spaces.Box | None = None

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        self._queue.clear()
        self._query_ms = []
        self.step = 0
        self.action_space = action_space
        self.instruction = instruction
        self.seed = seed

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        if not self._queue:
            start = time.perf_counter()
            chunk = self.query(observation)
            self._query_ms.append((time.perf_counter() - start) * 1000.0)
            self._queue.extend(chunk[: self.open_loop_horizon])
        self.step += 1
        return self._queue.popleft()

    def query(self, observation: dict[str, Any]) -> np.ndarray:
        """One round trip to the policy: a checked float32 chunk (H, 8)."""
        raise NotImplementedError

    def command_line_options(self) -> list[str]:
        options = ["--open-loop-horizon", str(self.open_loop_horizon)]
        for name in ("host", "port", "timeout"):
            if hasattr(self, name):
                options += [f"--{name}", f"{getattr(self, name):g}" if name == "timeout" else str(getattr(self, name))]
        return options

    def pop_query_times(self) -> list[float]:
        times, self._query_ms = self._query_ms, []
        return times

    def episode_fields(self) -> dict[str, Any]:
        """Episode-defining values a robolab_ms server uses to seed and position the served policy."""
        episode = self.episode
        fields: dict[str, Any] = {"step": self.step, "seed": int(self.seed)}
        if episode is not None:
            fields.update(task=episode.task, instruction_variant=episode.instruction_variant, robot=episode.robot)
        if self.action_space is not None:
            fields.update(action_low=np.asarray(self.action_space.low, dtype=np.float32),
                          action_high=np.asarray(self.action_space.high, dtype=np.float32))  # fmt: skip
        return fields
