"""What every remote policy client shares: reaching the server, action chunks executed open loop, checking replies.

A remote policy answers a query with a chunk of actions (H x 8); the client executes the first
`open_loop_horizon` of them, one per control step, before it asks again. Every fault of the server shows up as one
of the `PolicyError`s: the runner records the episode as errored with the message and goes on.

In real time (`robolab eval --realtime`) the policy's latency passes in simulated time; see `ChunkedPolicy`.
"""

from __future__ import annotations

import math
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
        raise PolicyReplyError(
            f"{source}: '{key}' has shape {chunk.shape}; expected (H, {action_dim}): H actions "
            f"of 7 joint targets and the gripper"
        )
    if not np.isfinite(chunk).all():
        bad = "NaN" if np.isnan(chunk).any() else "infinity"
        raise PolicyReplyError(f"{source}: '{key}' holds {bad}")
    return chunk.astype(np.float32)


class ChunkedPolicy(Policy):
    """A policy that answers in chunks: `query` returns (H, 8); the first `open_loop_horizon` actions are executed
    before the next query. Subclasses implement `query` and, for servers, `connect` and `close`.

    Real time (`realtime=True`, `robolab eval --realtime`): the policy's latency passes in simulated time at the
    control rate (CONTROL_HZ, 15 Hz) instead of stopping the simulation. For a query sent with the observation of
    step k whose reply is in hand after L seconds (the whole round trip, measured):

    - the reply arrives at step k + d, d = ceil(L * 15) (at least 1); until then the arm goes on with the chunk it
      has, and where that has no action for a step it holds its last target (at the episode start: where it
      stands); such a step counts as held;
    - the chunk's action i is the target for step k + i (the chunk starts at its observation's time), so actions
      0 .. d-1 are stale and skipped: from step k + d the chunk executes from action d on, to its last action,
      replacing what was left of the previous chunk; a reply of d >= H steps brings nothing but a new query;
    - one query is in flight at a time; the next goes out at the first step where none is in flight and either
      `open_loop_horizon` steps have passed since the previous query's observation or the arm has no action for
      the step (the client asks every `open_loop_horizon` steps, or as soon as a slower reply is in).

    The query is measured with the simulation paused and the steps it spans are simulated afterwards, with the
    actions they would have had (known before the reply: the old chunk, or holds). Stepping the simulation during
    the query would not change those actions, but would distort L: a simulation step holds Python's interpreter
    lock for its whole length, so the reply would be read up to a step late (measured on a 2-core machine without a
    GPU: a 17 ms query measured at 310 ms). So what is executed depends on the measured latencies only, not on how
    fast the machine simulates. With zero latency this is the synchronous schedule. A fault of the server errors
    the episode at once, as without --realtime.
    """

    def __init__(self, open_loop_horizon: int, realtime: bool = False) -> None:
        if open_loop_horizon < 1:
            raise PolicyUnavailableError(f"--open-loop-horizon must be at least 1, got {open_loop_horizon}")
        self.open_loop_horizon = open_loop_horizon
        self.realtime = realtime
        self._queue: deque[np.ndarray] = deque()
        self._query_ms: list[float] = []
        self.step = 0
        self._request_step = 0  # the step of the latest query's observation
        self.action_space: spaces.Box | None = None
        if realtime:
            from robolab_ms.tasks.spec import CONTROL_HZ

            self.control_hz = CONTROL_HZ
        self._chunk: np.ndarray | None = (
            None  # real time: the chunk executing; its action i is for step _chunk_step + i
        )
        self._chunk_step = 0
        self._reply: tuple[np.ndarray, int, int] | None = None  # a reply in flight: chunk, its step, arrival step
        self._last_action: np.ndarray | None = None
        self.held_steps = 0

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        self._queue.clear()
        self._query_ms = []
        self.step = self._request_step = self.held_steps = 0
        self._chunk, self._reply, self._last_action = None, None, None
        self.action_space = action_space
        self.instruction = instruction
        self.seed = seed

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        if self.realtime:
            action = self._act_in_real_time(observation)
        else:
            if not self._queue:
                self._queue.extend(self._timed_query(observation)[: self.open_loop_horizon])
            action = self._queue.popleft()
        self.step += 1
        return action

    def _timed_query(self, observation: dict[str, Any]) -> np.ndarray:
        self._request_step = self.step
        start = time.perf_counter()
        chunk = self.query(observation)
        self._query_ms.append((time.perf_counter() - start) * 1000.0)
        return chunk

    def _act_in_real_time(self, observation: dict[str, Any]) -> np.ndarray:
        step = self.step
        if self._reply is not None and step >= self._reply[2]:
            self._chunk, self._chunk_step, _ = self._reply
            self._reply = None
        action = self._chunk_action(step)
        if self._reply is None and (action is None or step >= self._request_step + self.open_loop_horizon):
            chunk = self._timed_query(observation)
            delay = max(1, math.ceil(self._query_ms[-1] / 1000.0 * self.control_hz))
            self._reply = (chunk, step, step + delay)
        if action is None:  # nothing has arrived for this step: hold
            self.held_steps += 1
            action = self._last_action if self._last_action is not None else self._standing_target(observation)
        self._last_action = action
        return action

    def _chunk_action(self, step: int) -> np.ndarray | None:
        if self._chunk is None or not 0 <= step - self._chunk_step < len(self._chunk):
            return None
        return self._chunk[step - self._chunk_step]

    @staticmethod
    def _standing_target(observation: dict[str, Any]) -> np.ndarray:
        """The target that keeps the arm where it stands: its joint positions and the gripper's."""
        joints = np.asarray(observation["joint_position"], dtype=np.float32).reshape(-1)
        gripper = np.asarray(observation["gripper_position"], dtype=np.float32).reshape(-1)[:1]
        return np.concatenate([joints, gripper])

    def query(self, observation: dict[str, Any]) -> np.ndarray:
        """One round trip to the policy: a checked float32 chunk (H, 8)."""
        raise NotImplementedError

    def command_line_options(self) -> list[str]:
        options = ["--open-loop-horizon", str(self.open_loop_horizon)]
        for name in ("host", "port", "timeout"):
            if hasattr(self, name):
                options += [f"--{name}", f"{getattr(self, name):g}" if name == "timeout" else str(getattr(self, name))]
        if self.realtime:
            options.append("--realtime")
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
            fields.update(
                action_low=np.asarray(self.action_space.low, dtype=np.float32),
                action_high=np.asarray(self.action_space.high, dtype=np.float32),
            )
        return fields
