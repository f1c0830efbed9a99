"""Policies. Every policy derives from `Policy`; `make_policy(name, options)` builds one by its name.

Names: `random`, `hold`, the privileged `oracle`, `replay` (actions recorded by an earlier run), the remote clients
`openpi` (websocket, robolab_ms.policies.openpi) and `gr00t` (ZMQ, robolab_ms.policies.gr00t), and
`module.path:factory` for any in-process policy in LeRobot's style (robolab_ms.policies.lerobot).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from robolab_ms.errors import RoboLabError, UnknownNameError


@dataclass(frozen=True)
class EpisodeInfo:
    """What defines the episode a policy is about to play (the runner passes it before `reset`)."""

    task: str
    instruction_variant: str
    instruction: str
    robot: str
    seed: int


@dataclass(frozen=True)
class PolicyOptions:
    """Options of the policies that need any; each policy reads the ones it uses.

    host, port: where a policy server listens (openpi, gr00t; port None = the protocol's default).
    open_loop_horizon: actions of each returned chunk executed before the server is asked again.
    timeout: seconds to wait for one reply before the episode is recorded as errored.
    replay_from: a results folder written with `--save-actions` (replay).
    replay_policy: whose recorded actions to replay when that folder holds several policies' (replay).
    action_horizon: length of the chunks a served policy answers with (`robolab serve`).
    gr00t_version: the GR00T server's request format: `n1.6` (data = {"observation": ..., "options": ...},
        replies [actions, info]; GR00T N1.6's server with its sim policy wrapper) or `n1.5` (data = the
        observation, replies the actions).
    results_name: the name results are filed under instead of the policy's own (e.g. `pi05` for an openpi
        server), so runs of two servers of one protocol can be compared and ranked.
    realtime: the remote policy's measured latency passes in simulated time instead of stopping the simulation
        (`robolab eval --realtime`; the schedule is robolab_ms.policies.remote.ChunkedPolicy's).
    """

    host: str = "127.0.0.1"
    port: int | None = None
    open_loop_horizon: int = 8
    timeout: float = 60.0
    replay_from: Path | None = None
    replay_policy: str | None = None
    action_horizon: int = 10
    gr00t_version: str = "n1.6"
    results_name: str | None = None
    realtime: bool = False


class PolicyError(RoboLabError):
    """A policy could not answer for this episode: the episode is recorded as errored with this reason."""


class PolicyUnavailableError(PolicyError):
    """The policy cannot be reached at all (no server at the address, or it did not come back): the run stops."""


class PolicyConnectionLost(PolicyError):
    """The connection to the policy server broke mid-episode."""


class PolicyTimeout(PolicyError):
    """The policy server did not answer within the timeout."""


class PolicyReplyError(PolicyError):
    """The policy's answer is unusable: wrong shape or dtype, NaN or infinity, a missing key, a server error."""


class Policy:
    """What the evaluation runner talks to: reset once per episode, then one 8-D DROID action per control step.

    Attributes:
        name: the name results are filed under.
        made_as: the name `make_policy` made it by (`--policy`), when results are filed under another name
            (`--policy-name`); None otherwise.
        needs_images: whether `act` reads camera images. The runner then makes the env with RGB observations and
            passes DROID's keys (robolab_ms.envs.DroidObservation: `exterior_image_1_left`, `wrist_image_left`,
            `joint_position`, `gripper_position`, `eef_pose`, `prompt`, each with a leading env dimension);
            otherwise `act` gets the env's state observation.
        reads_observations: False for a policy whose `act` never looks at its argument (the random policy): the
            runner then makes the env without observations (`obs_mode="none"`), which saves building them every
            step, and `act` gets an empty dict.
        privileged: whether it reads the simulator's true state (the runner then calls `bind(env)` after each
            environment reset); only reference policies such as the oracle do.
        endpoint: where the policy runs: `in-process`, a server address (`ws://host:port`, `tcp://host:port`) or
            a `module:factory` path; recorded with every episode.
        episode: the episode being played, set by `start_episode` before `reset`.
        realtime: whether the policy's latency passes in simulated time (`--realtime`; remote clients only).
        held_steps: in real time, the steps of this episode at which the arm held its last target because no
            action had arrived.
    """

    name: str = "policy"
    made_as: str | None = None
    needs_images: bool = True
    reads_observations: bool = True
    privileged: bool = False
    endpoint: str = "in-process"
    episode: EpisodeInfo | None = None
    needs_reconnect: bool = False  # set by remote policies after a fault; the runner then calls connect() again
    realtime: bool = False
    held_steps: int = 0

    def connect(self) -> None:
        """Make sure the policy can answer before any episode runs (remote policies: reach the server).

        Raises PolicyUnavailableError, whose message says how to fix it."""

    def metadata(self) -> dict[str, Any]:
        """What the policy says about itself (a server's metadata); recorded with every episode."""
        return {}

    def bind(self, env: Any) -> None:
        """Privileged policies only: the environment whose state `act` may read."""

    def start_episode(self, episode: EpisodeInfo) -> None:
        """The episode about to start (called before `reset`)."""
        self.episode = episode

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        """Start an episode with this instruction; `action_space` is the env's unbatched DROID action space.
        A policy that draws random numbers seeds them from `seed`, so an episode is a function of its seed."""

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """The next action: 7 absolute joint targets (rad) and the gripper (0 open, 1 closed)."""
        raise NotImplementedError

    def act_chunk(self, observation: dict[str, Any], step: int, horizon: int) -> np.ndarray:
        """`horizon` actions from this observation at episode step `step`, (horizon, 8): what a policy server
        sends back. The default asks `act` `horizon` times; policies that know a whole chunk override it."""
        return np.stack([np.asarray(self.act(observation), dtype=np.float32) for _ in range(horizon)])

    def command_line_options(self) -> list[str]:
        """The `robolab eval` options that recreate this policy (besides --policy NAME)."""
        return []

    def pop_query_times(self) -> list[float] | None:
        """Milliseconds of each query since the last call, for policies that answer in chunks (one query feeds
        several steps); None when every `act` call is one query (the runner then times `act` itself)."""
        return None

    def close(self) -> None:
        """Release connections and other resources."""


class RandomPolicy(Policy):
    """Uniformly random actions within the action space; the floor every policy should beat."""

    name = "random"
    needs_images = False
    reads_observations = False

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        self.space = spaces.Box(action_space.low, action_space.high, dtype=np.float32)
        self.space.seed(seed)
        self._bounded = self.space.is_bounded()
        self._low = self.space.low.astype(np.float64)
        self._range = self.space.high.astype(np.float64) - self._low

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        if not self._bounded:
            return self.space.sample()
        # Box.sample's draw for a space bounded on every side, low + range * U as numpy's `uniform` makes it (the
        # same numbers), without the masks of `sample` and the argument checks of `uniform` at every call
        space = self.space
        return (self._low + self._range * space.np_random.random(space.shape)).astype(np.float32)


class HoldPolicy(Policy):
    """Holds the arm where it is with the gripper open, and answers at once: for checking a set-up
    (`robolab serve --policy hold`) and for measuring what the evaluation path itself costs."""

    name = "hold"
    needs_images = True  # it reads DROID's joint_position

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        joints = np.asarray(observation["joint_position"], dtype=np.float32).reshape(-1)
        return np.append(joints, np.float32(0.0))


def _oracle(options: PolicyOptions) -> Policy:
    from robolab_ms.policies.oracle import OraclePolicy  # imports the motion planner only when asked for

    return OraclePolicy()


def _replay(options: PolicyOptions) -> Policy:
    from robolab_ms.policies.replay import ReplayPolicy

    return ReplayPolicy(options.replay_from, options.replay_policy)


def _openpi(options: PolicyOptions) -> Policy:
    from robolab_ms.policies.openpi import OpenPIPolicy

    return OpenPIPolicy(
        options.host, options.port or 8000, options.open_loop_horizon, options.timeout, options.realtime
    )


def _gr00t(options: PolicyOptions) -> Policy:
    from robolab_ms.policies.gr00t import Gr00tPolicy

    return Gr00tPolicy(
        options.host,
        options.port or 5555,
        options.open_loop_horizon,
        options.timeout,
        options.gr00t_version,
        options.realtime,
    )


POLICIES: dict[str, Callable[[PolicyOptions], Policy]] = {
    "random": lambda options: RandomPolicy(),
    "hold": lambda options: HoldPolicy(),
    "oracle": _oracle,
    "replay": _replay,
    "openpi": _openpi,
    "gr00t": _gr00t,
}


def make_policy(name: str, options: PolicyOptions | None = None) -> Policy:
    """The policy registered under `name`, or an in-process LeRobot-style policy for `module.path:factory`."""
    options = options or PolicyOptions()
    if ":" in name:
        from robolab_ms.policies.lerobot import load_lerobot_policy

        policy = load_lerobot_policy(name)
    elif name not in POLICIES:
        raise UnknownNameError("policy", name, [*POLICIES, "module.path:factory"])
    else:
        policy = POLICIES[name](options)
    if options.realtime and not policy.realtime:
        policy.close()
        raise RoboLabError(
            f"--realtime: policy '{name}' computes in this process; --realtime passes a policy server's measured "
            "latency in simulated time and is for the clients openpi and gr00t. To evaluate this policy in real "
            f"time, serve it (`robolab serve --policy {name}`) and run `robolab eval --policy openpi --realtime`; "
            "the oracle reads the simulator and cannot be served"
        )
    if options.results_name is not None:
        policy.made_as, policy.name = name, options.results_name
    return policy
