"""Policy clients. Every policy derives from `Policy`; `make_policy(name)` builds one by its registered name."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces

from robolab_ms.errors import UnknownNameError


class Policy:
    """What the evaluation runner talks to: reset once per episode, then one 8-D DROID action per control step.

    Attributes:
        name: the name results are filed under.
        needs_images: whether `act` reads camera images (the runner then asks the env for RGB observations).
        privileged: whether it reads the simulator's true state (the runner then calls `bind(env)` after each
            environment reset); only reference policies such as the oracle do.
    """

    name: str = "policy"
    needs_images: bool = True
    privileged: bool = False

    def bind(self, env: Any) -> None:
        """Privileged policies only: the environment whose state `act` may read."""

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        """Start an episode with this instruction; `action_space` is the env's unbatched DROID action space."""

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """The next action: 7 absolute joint targets (rad) and the gripper (0 open, 1 closed)."""
        raise NotImplementedError


class RandomPolicy(Policy):
    """Uniformly random actions within the action space; the floor every policy should beat."""

    name = "random"
    needs_images = False

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        self.space = spaces.Box(action_space.low, action_space.high, dtype=np.float32)
        self.space.seed(seed)

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        return self.space.sample()


def _oracle() -> Policy:
    from robolab_ms.policies.oracle import OraclePolicy  # imports the motion planner only when asked for

    return OraclePolicy()


POLICIES: dict[str, Callable[[], Policy]] = {"random": RandomPolicy, "oracle": _oracle}


def make_policy(name: str) -> Policy:
    if name not in POLICIES:
        raise UnknownNameError("policy", name, POLICIES)
    return POLICIES[name]()
