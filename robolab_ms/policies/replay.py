"""The replay policy: the actions an earlier run recorded (`robolab eval --save-actions`), step by step.

`robolab eval --save-actions --out DIR` writes one file per episode, DIR/actions/<policy>/<task>/<variant>-<robot>-
seed<N>.npy (float32, steps x 8). `--policy replay --replay-from DIR` plays them back for the same task, variant,
robot and seed, in process or served by `robolab serve --policy replay --replay-from DIR`; with deterministic
episodes it reproduces the recorded run's success, score and step count. After the last recorded action it holds
that action.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from robolab_ms.errors import RoboLabError
from robolab_ms.policies import Policy, PolicyError

ACTIONS_DIR = "actions"


def actions_file(out_dir: Path, policy: str, task: str, variant: str, robot: str, seed: int) -> Path:
    """Where `--save-actions` keeps one episode's actions."""
    safe_policy = policy.replace("/", "_").replace(":", "_")
    return Path(out_dir) / ACTIONS_DIR / safe_policy / task / f"{variant}-{robot}-seed{seed}.npy"


def save_actions(path: Path, actions: list[np.ndarray]) -> None:
    """Write an episode's actions (steps x 8, float32) atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    array = np.asarray(actions, dtype=np.float32).reshape(len(actions), -1) if actions else np.zeros((0, 8), np.float32)
    partial = path.with_name(path.name + ".partial")
    with partial.open("wb") as handle:
        np.save(handle, array, allow_pickle=False)
    partial.replace(path)


class ReplayPolicy(Policy):
    """Plays back recorded actions of the same (task, variant, robot, seed)."""

    name = "replay"
    needs_images = False
    reads_observations = False

    def __init__(self, replay_from: Path | str | None, replay_policy: str | None = None) -> None:
        if replay_from is None:
            raise RoboLabError(
                "the replay policy needs --replay-from DIR: a results folder written by "
                "`robolab eval --save-actions --out DIR`"
            )
        folder = Path(replay_from)
        root = folder / ACTIONS_DIR
        recorded = sorted(p.name for p in root.iterdir() if p.is_dir()) if root.is_dir() else []
        if not recorded:
            raise RoboLabError(
                f"{folder}: no recorded actions (no {ACTIONS_DIR}/ folder with episodes). Record them "
                f"with `robolab eval --policy NAME --save-actions --out {folder}`"
            )
        if replay_policy is None:
            if len(recorded) > 1:
                raise RoboLabError(
                    f"{folder} holds recorded actions of several policies ({', '.join(recorded)}): "
                    "choose one with --replay-policy NAME"
                )
            replay_policy = recorded[0]
        elif replay_policy.replace(":", "_") not in recorded:
            raise RoboLabError(
                f"{folder} holds no recorded actions of policy '{replay_policy}' "
                f"(it has {', '.join(recorded)}); use --replay-policy with one of those"
            )
        self.folder, self.source = folder, replay_policy
        self.endpoint = f"replay of {replay_policy} in {folder}"
        self.actions = np.zeros((0, 8), np.float32)
        self.step = 0

    def command_line_options(self) -> list[str]:
        return ["--replay-from", str(self.folder), "--replay-policy", self.source]

    def metadata(self) -> dict[str, Any]:
        return {"replay_from": str(self.folder), "replayed_policy": self.source}

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        episode = self.episode
        if episode is None:
            raise PolicyError("the replay policy needs the episode's task, variant and robot (start_episode)")
        path = actions_file(self.folder, self.source, episode.task, episode.instruction_variant, episode.robot, seed)
        if not path.exists():
            raise PolicyError(
                f"no recorded actions for {episode.task} ({episode.instruction_variant}, "
                f"{episode.robot}) seed {seed}: {path} is missing"
            )
        self.actions = np.load(path, allow_pickle=False)
        if len(self.actions) == 0:
            raise PolicyError(f"{path} holds no actions")
        self.step = 0

    def _slice(self, start: int, count: int) -> np.ndarray:
        index = np.minimum(np.arange(start, start + count), len(self.actions) - 1)
        return self.actions[index]

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        action = self._slice(self.step, 1)[0]
        self.step += 1
        return action

    def act_chunk(self, observation: dict[str, Any], step: int, horizon: int) -> np.ndarray:
        self.step = step + horizon
        return self._slice(step, horizon)
