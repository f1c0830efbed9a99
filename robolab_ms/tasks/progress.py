"""Subtask progress and score: a batched state machine over stages, groups and ordered weighted conditions.

A task's subtasks are stages run strictly in order. A stage holds parallel groups (usually one per target object);
a group is an ordered list of conditions with weights, e.g. [grasped: 0, in the bowl and released: 1]. Every step,
for every environment at once:
- a group jumps ahead to its furthest condition that holds now;
- otherwise, if a condition it had completed no longer holds, it falls back to the earliest such one;
- a group that completed its last condition stays completed (latched).
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


class ProgressTracker:
    """Tracks the stages of one task for `num_envs` environments."""

    def __init__(self, stages: list[Stage], num_envs: int, device: torch.device | str = "cpu") -> None:
        if not stages:
            raise ValueError("a task needs at least one stage")
        self.stages = stages
        self.num_envs = num_envs
        self.device = torch.device(device)
        self.stage_index = torch.zeros(num_envs, dtype=torch.long, device=self.device)
        # levels[s]: (num_envs, num_groups) how many conditions each group of stage s has completed
        self.levels = [torch.zeros(num_envs, len(stage.groups), dtype=torch.long, device=self.device) for stage in stages]

    def reset(self, env_idx: torch.Tensor | None = None) -> None:
        env_idx = slice(None) if env_idx is None else env_idx
        self.stage_index[env_idx] = 0
        for levels in self.levels:
            levels[env_idx] = 0

    def update(self, holds: torch.Tensor) -> torch.Tensor:
        """Advance with this step's condition truth (num_envs, num_conditions) bool; returns the score (num_envs,)."""
        score = torch.zeros(self.num_envs, device=self.device)
        for s, stage in enumerate(self.stages):
            active = self.stage_index == s
            for g, group in enumerate(stage.groups):
                levels = self.levels[s][:, g]
                new_levels = _step_group(levels, holds[:, list(group.conditions)])
                levels.copy_(torch.where(active, new_levels, levels))
            done = self._stage_done(s)
            self.stage_index = torch.where(active & done, self.stage_index + 1, self.stage_index)
        for s in range(len(self.stages)):
            current = self.stage_index == s
            score = torch.where(current, s + self._stage_score(s), score)
        score = torch.where(self.stage_index >= len(self.stages), float(len(self.stages)), score)
        return score / len(self.stages)

    def progress(self) -> torch.Tensor:
        """Fraction of all conditions of all groups completed so far (num_envs,), a finer view than the score."""
        completed = sum(levels.sum(dim=1) for levels in self.levels)
        total = sum(len(group.conditions) for stage in self.stages for group in stage.groups)
        return completed.float() / total

    def _group_scores(self, s: int) -> torch.Tensor:
        columns = []
        for g, group in enumerate(self.stages[s].groups):
            weights = torch.tensor(group.weights, device=self.device)
            if float(weights.sum()) == 0:
                weights = torch.ones_like(weights)
            cumulative = torch.cat([torch.zeros(1, device=self.device), weights.cumsum(0)]) / weights.sum()
            columns.append(cumulative[self.levels[s][:, g]])
        return torch.stack(columns, dim=1)

    def _stage_score(self, s: int) -> torch.Tensor:
        stage, scores = self.stages[s], self._group_scores(s)
        if stage.logical == "all":
            return scores.mean(dim=1)
        if stage.logical == "any":
            return scores.max(dim=1).values
        k = min(stage.k, scores.shape[1])
        return scores.topk(k, dim=1).values.mean(dim=1)

    def _stage_done(self, s: int) -> torch.Tensor:
        stage = self.stages[s]
        lengths = torch.tensor([len(group.conditions) for group in stage.groups], device=self.device)
        complete = self.levels[s] >= lengths
        if stage.logical == "all":
            return complete.all(dim=1)
        if stage.logical == "any":
            return complete.any(dim=1)
        return complete.sum(dim=1) >= stage.k


def _step_group(levels: torch.Tensor, holds: torch.Tensor) -> torch.Tensor:
    """One step of one group for all environments: jump ahead, fall back, or stay; a finished group is latched."""
    num_conditions = holds.shape[1]
    positions = torch.arange(1, num_conditions + 1, device=holds.device)
    furthest = (holds * positions).max(dim=1).values  # 0 when nothing holds
    completed = positions.unsqueeze(0) <= levels.unsqueeze(1)
    broken = completed & ~holds
    first_broken = torch.where(broken, positions - 1, num_conditions).min(dim=1).values
    fallen = torch.minimum(levels, first_broken)
    new_levels = torch.where(furthest > levels, furthest, fallen)
    return torch.where(levels >= num_conditions, levels, new_levels)
