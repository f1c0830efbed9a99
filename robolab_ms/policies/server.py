"""`robolab serve`: any of our policies behind a policy server, so the whole remote path runs on one machine.

Two protocols:
- `openpi` (default, port 8000): a websocket server speaking openpi's protocol: on connect it sends its metadata
  (msgpack-numpy), then answers each observation frame with `{"actions": (H, 8), "server_timing": ...}`; an error
  goes back as a text frame and the connection is closed, as openpi's own server does. Several clients at once,
  each with its own policy instance.
- `gr00t` (port 5555): a ZMQ reply socket speaking GR00T's protocol: `{"endpoint": "get_action", "data": {...}}`
  requests, numpy arrays as `.npy` bytes inside msgpack, `{"action.joint_position", "action.gripper_position"}`
  replies (as `[actions, info]` to N1.6-style requests, whose data is `{"observation": ..., "options": ...}`);
  `ping` answers with the metadata.

The served policy is reset when an episode starts: a robolab_ms client sends the episode's task, variant, robot,
seed and step with each observation (`robolab/*` keys for openpi, `robolab.*` for GR00T), so the served policy is
seeded from the episode seed and a replay is positioned at the right step; a foreign client's episode is the
connection's first request onwards, seed 0. A delay (`--delay-ms`) holds every answer back until that long after
its request came in, so a fast policy stands in for a slower one (for `robolab eval --realtime`).
"""

from __future__ import annotations

import asyncio
import logging
import socket
import subprocess
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from robolab_ms.policies import EpisodeInfo, Policy

log = logging.getLogger("robolab_ms.serve")

PROTOCOLS = {"openpi": 8000, "gr00t": 5555}
MAX_GR00T_SESSIONS = 32  # episodes kept apart on a GR00T server (its clients are not told apart otherwise)


def _default_action_space(robot: str) -> spaces.Box:
    """DROID's action space, for clients that do not send theirs."""
    from robolab_ms.agents.droid_model import ARM_LOWER, ARM_UPPER

    return spaces.Box(
        np.array([*ARM_LOWER, 0.0], np.float32), np.array([*ARM_UPPER, 1.0], np.float32), dtype=np.float32
    )


def episode_key(episode: dict[str, Any]) -> tuple:
    """What tells a client's episodes apart: task, variant, robot and seed (None for a foreign client)."""
    return tuple(episode.get(name) for name in ("task", "instruction_variant", "robot", "seed"))


class PolicySession:
    """One client's served policy: resets it when an episode starts and answers observations with chunks."""

    def __init__(self, policy: Policy, action_horizon: int, delay: float = 0.0) -> None:
        self.policy = policy
        self.action_horizon = action_horizon
        self.delay = delay  # s: the least time an answer takes
        self.episode_key: tuple | None = None
        self.step = 0

    def answer(self, observation: dict[str, Any], episode: dict[str, Any]) -> np.ndarray:
        """The chunk (action_horizon, 8) for a DROID observation dict (batched arrays) and the client's episode
        fields (task, instruction_variant, robot, seed, step, action_low, action_high; any may be missing)."""
        start = time.perf_counter()
        key = episode_key(episode)
        step = episode.get("step")
        if self.episode_key is None or key != self.episode_key or step == 0:
            self._start(observation, episode)
            self.episode_key = key
            self.step = 0
        step = int(step) if step is not None else self.step
        chunk = np.asarray(self.policy.act_chunk(observation, step, self.action_horizon), dtype=np.float32)
        self.step = step + len(chunk)
        time.sleep(max(0.0, self.delay - (time.perf_counter() - start)))
        return chunk

    def _start(self, observation: dict[str, Any], episode: dict[str, Any]) -> None:
        robot = str(episode.get("robot") or "droid")
        seed = int(episode.get("seed") or 0)
        if episode.get("action_low") is not None and episode.get("action_high") is not None:
            low, high = (np.asarray(episode[key], np.float32) for key in ("action_low", "action_high"))
            space = spaces.Box(low, high, dtype=np.float32)
        else:
            space = _default_action_space(robot)
        prompt = str(observation.get("prompt", ""))
        self.policy.start_episode(
            EpisodeInfo(
                task=str(episode.get("task") or ""),
                instruction_variant=str(episode.get("instruction_variant") or ""),
                instruction=prompt,
                robot=robot,
                seed=seed,
            )
        )
        self.policy.reset(prompt, space, seed)


def server_metadata(policy: Policy, protocol: str, action_horizon: int) -> dict[str, Any]:
    from importlib.metadata import PackageNotFoundError, version

    try:
        robolab_version = version("robolab-ms")
    except PackageNotFoundError:
        robolab_version = "checkout"
    return {
        "server": "robolab_ms",
        "protocol": protocol,
        "policy": policy.name,
        "action_horizon": action_horizon,
        "action_dim": 8,
        "robolab_ms_version": robolab_version,
        **policy.metadata(),
    }


# ---------------------------------------------------------------------------------------------------- openpi
def _openpi_observation(request: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """openpi DROID request -> (DROID observation with a leading env dimension, robolab episode fields)."""
    observation: dict[str, Any] = {}
    episode: dict[str, Any] = {}
    for key, value in request.items():
        if key.startswith("observation/"):
            observation[key.removeprefix("observation/")] = np.asarray(value)[None]
        elif key.startswith("robolab/"):
            episode[key.removeprefix("robolab/")] = value
        elif key == "prompt":
            observation["prompt"] = str(value)
    return observation, episode


def _log_request(peer: Any, episode: dict[str, Any], chunk: np.ndarray, seconds: float) -> None:
    print(
        f"request from {peer}: task {episode.get('task')} seed {episode.get('seed')} step {episode.get('step')}: "
        f"{len(chunk)} actions in {seconds * 1000:.1f} ms",
        flush=True,
    )


async def _serve_openpi(
    factory: Callable[[], Policy],
    host: str,
    port: int,
    action_horizon: int,
    ready: Callable[[], None],
    log_requests: bool,
    delay: float,
) -> None:
    import http

    import websockets.asyncio.server as ws_server
    import websockets.frames
    from openpi_client import msgpack_numpy

    async def handle(connection: Any) -> None:
        policy = await asyncio.to_thread(factory)
        session = PolicySession(policy, action_horizon, delay)
        peer = connection.remote_address
        log.info("client %s connected", peer)
        packer = msgpack_numpy.Packer()
        try:
            await connection.send(packer.pack(server_metadata(policy, "openpi", action_horizon)))
            while True:
                message = await connection.recv()
                start = time.perf_counter()
                try:
                    if isinstance(message, str):
                        raise ValueError("expected a binary msgpack frame, got text")
                    observation, episode = _openpi_observation(msgpack_numpy.unpackb(message))
                    chunk = await asyncio.to_thread(session.answer, observation, episode)
                except Exception:
                    await connection.send(traceback.format_exc())
                    await connection.close(
                        code=websockets.frames.CloseCode.INTERNAL_ERROR, reason="policy error (traceback sent)"
                    )
                    return
                reply = {"actions": chunk, "server_timing": {"infer_ms": (time.perf_counter() - start) * 1000.0}}
                if log_requests:
                    _log_request(peer, episode, chunk, time.perf_counter() - start)
                await connection.send(packer.pack(reply))
        except websockets.ConnectionClosed:
            pass
        finally:
            policy.close()
            log.info("client %s gone", peer)

    def health(connection: Any, request: Any) -> Any:
        if request.path == "/healthz":
            return connection.respond(http.HTTPStatus.OK, "OK\n")
        return None

    async with ws_server.serve(handle, host, port, compression=None, max_size=None, process_request=health):
        ready()
        await asyncio.get_running_loop().create_future()  # until interrupted


# ---------------------------------------------------------------------------------------------------- GR00T
def _serve_gr00t(
    factory: Callable[[], Policy],
    host: str,
    port: int,
    action_horizon: int,
    ready: Callable[[], None],
    log_requests: bool,
    delay: float,
) -> None:
    import zmq

    from robolab_ms.policies.gr00t import gr00t_request_to_droid, pack, unpack

    context = zmq.Context()
    sock = context.socket(zmq.REP)
    sock.bind(f"tcp://{'*' if host in ('0.0.0.0', '') else host}:{port}")
    policy = factory()
    sessions: dict[tuple, PolicySession] = {}
    metadata = server_metadata(policy, "gr00t", action_horizon)
    ready()
    try:
        while True:
            request = unpack(sock.recv())
            start = time.perf_counter()
            try:
                endpoint = request.get("endpoint", "get_action") if isinstance(request, dict) else None
                if endpoint == "ping":
                    reply: Any = {"status": "ok", **metadata}
                elif endpoint == "get_action":
                    observation, episode = gr00t_request_to_droid(request.get("data") or {})
                    key = episode_key(episode)
                    session = sessions.pop(key, None) or PolicySession(factory(), action_horizon, delay)
                    sessions[key] = session  # the most recent last; clients' episodes may interleave
                    while len(sessions) > MAX_GR00T_SESSIONS:
                        sessions.pop(next(iter(sessions))).policy.close()
                    chunk = session.answer(observation, episode)
                    reply = {
                        "action.joint_position": chunk[None, :, :-1],
                        "action.gripper_position": chunk[None, :, -1:],
                    }
                    if isinstance(request["data"].get("observation"), dict):
                        reply = [reply, {}]  # N1.6's format: (actions, info)
                    if log_requests:
                        _log_request("a GR00T client", episode, chunk, time.perf_counter() - start)
                else:
                    reply = {"error": f"unknown endpoint {endpoint!r}"}
            except Exception as exc:
                log.exception("request failed")
                reply = {"error": f"{type(exc).__name__}: {exc}"}
            sock.send(pack(reply))
    finally:
        sock.close(linger=0)
        context.term()


def serve(
    factory: Callable[[], Policy],
    host: str = "0.0.0.0",
    port: int | None = None,
    protocol: str = "openpi",
    action_horizon: int = 10,
    ready: Callable[[], None] | None = None,
    log_requests: bool = False,
    delay: float = 0.0,
) -> None:
    """Serve the policies `factory` makes until interrupted. `ready` is called once the port is open;
    `log_requests` prints one line per answered request; `delay` (s) is the least time an answer takes."""
    port = port or PROTOCOLS[protocol]
    ready = ready or (lambda: None)
    if protocol == "openpi":
        asyncio.run(_serve_openpi(factory, host, port, action_horizon, ready, log_requests, delay))
    elif protocol == "gr00t":
        _serve_gr00t(factory, host, port, action_horizon, ready, log_requests, delay)
    else:
        raise ValueError(f"unknown protocol {protocol!r}")


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port that is free on `host` now (for a server started next)."""
    with socket.socket() as sock:
        sock.bind((host, 0))
        return sock.getsockname()[1]


def start_serve_process(policy_args: Sequence[str], port: int, host: str = "127.0.0.1") -> subprocess.Popen:
    """`robolab serve` with `policy_args` (e.g. ["--policy", "hold"]) in a process of its own, returned once it
    listens on host:port; SystemExit if it ended before that."""
    server = subprocess.Popen(
        [sys.executable, "-m", "robolab_ms.cli", "serve", *policy_args, "--host", host, "--port", str(port)],
        stdout=subprocess.PIPE,
        text=True,
    )
    while "robolab serve:" not in (server.stdout.readline() or "robolab serve:"):
        pass
    if server.poll() is not None:
        raise SystemExit("robolab serve did not start")
    return server
