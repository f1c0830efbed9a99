"""Subtask progress and score: a batched state machine over stages, groups and ordered weighted conditions.

A task's subtasks are stages run strictly in order. A stage holds parallel groups (usually one per target object);
a group is an ordered list of conditions with weights, e.g. [grasped: 0, in the bowl and released: 1]. Every step,
for every environment at once:
- a group moves to its furthest condition that holds now: ahead of where it was, that is a jump; behind it (its
  current condition broke), a fall-back; to 0 when none holds;
- a group that completed its last condition stays completed (latched).
RoboLab states the fall-back as "to the earliest completed condition that no longer holds". Read literally, a group
whose first condition broke while a later one still holds (grasped no longer, but lifted) would fall to 0 and jump
back the next step, forever; here the furthest holding condition decides, so a steady scene gives a steady score.
A group's score is the weight of its completed conditions over its total weight. A stage's score is the mean of its
group scores (`all`), their maximum (`any`) or the mean of the best K (`choose`). The stage is done when all groups
(`all`), one (`any`) or at least K (`choose`) are complete; then the next stage starts. The episode score is the
number of done stages plus the current stage's score, over the number of stages: a value in [0, 1].
This module is pure torch and knows nothing of physics: it is fed the truth of every condition each step.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class Group:
    """Ordered conditions (indices into the per-step condition vector) with their weights."""

    conditions: tuple[int, ...]
    weights: tuple[float, ...]


@dataclass(frozen=True)
class Stage:
    groups: tuple[Group, ...]
    logical: str = "all"  # all | any | choose
    k: int = 1


class _StageTables:
    """A stage's groups as padded tensors, built once: column indices, validity, lengths, cumulative weights."""

    def __init__(self, stage: Stage, device: torch.device) -> None:
        width = max(len(group.conditions) for group in stage.groups)
        self.index = torch.zeros(len(stage.groups), width, dtype=torch.long, device=device)
        self.valid = torch.zeros(len(stage.groups), width, dtype=torch.bool, device=device)
        self.cumulative = torch.ones(len(stage.groups), width + 1, device=device)
        for g, group in enumerate(stage.groups):
            count = len(group.conditions)
            self.index[g, :count] = torch.tensor(group.conditions)
            self.valid[g, :count] = True
            weights = torch.tensor(group.weights, dtype=torch.float32)
            if float(weights.sum()) == 0:
                weights = torch.ones_like(weights)
            self.cumulative[g, : count + 1] = torch.cat([torch.zeros(1), weights.cumsum(0)]) / weights.sum()
        self.lengths = self.valid.sum(dim=1)
        self.positions = torch.arange(1, width + 1, device=device)
        self.width = width
        self.logical, self.k = stage.logical, stage.k


class ProgressTracker:
    """Tracks the stages of one task for `num_envs` environments."""

    def __init__(self, stages: list[Stage], num_envs: int, device: torch.device | str = "cpu") -> None:
        if not stages:
            raise ValueError("a task needs at least one stage")
        self.stages = stages
        self.num_envs = num_envs
        self.device = torch.device(device)
        self._tables = [_StageTables(stage, self.device) for stage in stages]
        self.stage_index = torch.zeros(num_envs, dtype=torch.long, device=self.device)
        # levels[s]: (num_envs, num_groups) how many conditions each group of stage s has completed
        self.levels = [
            torch.zeros(num_envs, len(stage.groups), dtype=torch.long, device=self.device) for stage in stages
        ]
        self._total_conditions = sum(len(group.conditions) for stage in stages for group in stage.groups)

    def reset(self, env_idx: torch.Tensor | None = None) -> None:
        env_idx = slice(None) if env_idx is None else env_idx
        self.stage_index[env_idx] = 0
        for levels in self.levels:
            levels[env_idx] = 0

    def update(self, holds: torch.Tensor) -> torch.Tensor:
        """Advance with this step's condition truth (num_envs, num_conditions) bool; returns the score (num_envs,)."""
        for s, table in enumerate(self._tables):
            active = self.stage_index == s
            levels = self.levels[s]
            new_levels = _step_groups(levels, holds[:, table.index] & table.valid, table)
            self.levels[s] = torch.where(active[:, None], new_levels, levels)
            done = _combine(self.levels[s] >= table.lengths, table.logical, table.k)
            self.stage_index = torch.where(active & done, self.stage_index + 1, self.stage_index)
        count = len(self._tables)
        score = torch.full((self.num_envs,), float(count), device=self.device)
        for s in range(count):
            score = torch.where(self.stage_index == s, s + self._stage_score(s), score)
        return score / count

    def progress(self) -> torch.Tensor:
        """Fraction of all conditions of all groups completed so far (num_envs,), a finer view than the score."""
        completed = sum(levels.sum(dim=1) for levels in self.levels)
        return completed.float() / self._total_conditions

    def _stage_score(self, s: int) -> torch.Tensor:
        table = self._tables[s]
        groups = torch.arange(len(table.lengths), device=self.device)
        scores = table.cumulative[groups, self.levels[s]]  # (num_envs, num_groups)
        if table.logical == "all":
            return scores.mean(dim=1)
        if table.logical == "any":
            return scores.amax(dim=1)
        return scores.topk(min(table.k, scores.shape[1]), dim=1).values.mean(dim=1)


def _combine(complete: torch.Tensor, logical: str, k: int) -> torch.Tensor:
    if logical == "all":
        return complete.all(dim=1)
    if logical == "any":
        return complete.any(dim=1)
    return complete.sum(dim=1) >= k


def _step_groups(levels: torch.Tensor, holds: torch.Tensor, table: _StageTables) -> torch.Tensor:
    """One step of every group of a stage, all environments at once: a group stands at its furthest condition that
    holds now (ahead of where it was: a jump; behind it: a fall-back, 0 when none holds); finished groups stay
    finished. levels: (E, G); holds: (E, G, C) with padding False."""
    furthest = (holds * table.positions).amax(dim=-1)
    return torch.where(levels >= table.lengths, levels, furthest)
