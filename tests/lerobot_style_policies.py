"""LeRobot-style policies for tests/test_policy_lerobot.py, loaded with `--policy lerobot_style_policies:NAME`."""

from __future__ import annotations

import torch

MADE: list[RecordingPolicy] = []


class RecordingPolicy:
    """Holds the arm where it is; remembers the batches it was given, its resets and one random draw per episode."""

    def __init__(self) -> None:
        self.batches: list[dict] = []
        self.resets = 0
        self.draws: list[float] = []

    def reset(self) -> None:
        self.resets += 1
        self.draws.append(float(torch.rand(1)))

    def select_action(self, batch: dict) -> torch.Tensor:
        self.batches.append(batch)
        state = batch["observation.state"]
        return torch.cat([state[:, :7], torch.zeros(1, 1)], dim=1)


class WrongShape(RecordingPolicy):
    def select_action(self, batch: dict) -> torch.Tensor:
        return torch.zeros(1, 6)


def make() -> RecordingPolicy:
    policy = RecordingPolicy()
    MADE.append(policy)
    return policy


def wrong_shape() -> WrongShape:
    return WrongShape()


def not_a_policy() -> object:
    return object()
