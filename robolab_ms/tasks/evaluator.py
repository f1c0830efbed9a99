"""TaskEvaluator: everything a task's evaluate() reports, for `num_envs` environments at once.

It owns the task's per-step logic: success conditions (OR'ed), the subtask progress tracker, and the event monitor,
all reading one EvalContext. The environment feeds it the step counter and the gripper's closed fraction.

Quiet steps. On the CPU simulator, a step in which every tracked object is asleep (PhysX moved none of them), the
fingers' contacts are exactly those of the previous step and (where events are tracked: no predicate reads it) the
gripper's closed fraction is on the same side of every event threshold, cannot change any predicate, the progress or
an event: the previous step's result is returned without evaluating anything. The previous step must itself have
been a full evaluation that left the subtask stage unchanged (a new stage reads its own conditions for the first
time). Reset, and the GPU simulator, always evaluate in full.
"""

from __future__ import annotations

import torch

from robolab_ms.tasks.context import EvalContext
from robolab_ms.tasks.events import EventMonitor
from robolab_ms.tasks.predicates import evaluate_condition, per_object
from robolab_ms.tasks.progress import ProgressTracker
from robolab_ms.tasks.spec import TaskSpec


class TaskEvaluator:
    """Success, score, progress, stage and events of one task, evaluated on an EvalContext."""

    def __init__(self, spec: TaskSpec, context: EvalContext) -> None:
        self.spec = spec
        self.context = context
        self.num_envs, self.device = context.num_envs, context.device
        self._progress_conditions, stages, stage_targets = spec.progress_layout()
        self.progress_tracker = ProgressTracker(stages, self.num_envs, self.device)
        contact = list(spec.contact_objects)
        # row s: which contact objects are targets while stage s runs: its own objects and those of earlier stages
        # (they were moved on purpose); the last row, after the end, holds every stage's objects
        rows, so_far = [], set()
        for targets in stage_targets:
            so_far |= set(targets)
            rows.append([name in so_far for name in contact])
        self._stage_targets = torch.tensor(rows + rows[-1:], dtype=torch.bool, device=self.device)
        self.events = EventMonitor(context, contact, spec.event_thresholds)
        self.track_events = True  # False: no event is detected or logged (success, score and progress as always)
        self._last: dict[str, torch.Tensor] | None = None  # the last full result, while it may be reused
        self._last_inputs: tuple[tuple, torch.Tensor] | None = None  # finger contacts, gripper closed levels
        self.quiet_steps = 0  # how many evaluations reused the previous result (for benchmarks and tests)

    def reset(self, env_idx: torch.Tensor) -> None:
        """Start new episodes in `env_idx`."""
        self.progress_tracker.reset(env_idx)
        self.context.reset(env_idx)
        self.events.reset(env_idx)
        self._last = self._last_inputs = None

    def evaluate(self, elapsed_steps: torch.Tensor, gripper_closed: torch.Tensor | None) -> dict[str, torch.Tensor]:
        """This step's success, score, progress, stage and `event_<type>` flags (which events fired), each (E,).
        `gripper_closed`: how far the gripper is closed, 0 open to 1 closed, (E,); only events read it (None will do
        where `track_events` is off)."""
        context = self.context
        context.refresh(elapsed_steps)
        finger_contacts = context.finger_contacts_if_at_rest()
        closed_levels = None  # only events read the gripper's closed fraction
        if finger_contacts is not None and self.track_events:
            closed_levels = self.events.closed_levels(gripper_closed)
        if finger_contacts is not None and self._last is not None:
            last_contacts, last_levels = self._last_inputs
            if closed_levels is None or last_levels is None:  # events not tracked (or not then)
                same_levels = closed_levels is None and last_levels is None
            else:
                same_levels = torch.equal(closed_levels, last_levels)
            if finger_contacts == last_contacts and same_levels:
                self.quiet_steps += 1
                return dict(self._last, **self.events.nothing_fired)
        stage_before = self.progress_tracker.stage_index
        result = self._evaluate_in_full(gripper_closed)
        reusable = finger_contacts is not None and torch.equal(result["stage"], stage_before)
        self._last = result if reusable else None
        self._last_inputs = (finger_contacts, closed_levels) if reusable else None
        return result

    def _evaluate_in_full(self, gripper_closed: torch.Tensor | None) -> dict[str, torch.Tensor]:
        context, tracker = self.context, self.progress_tracker
        success = evaluate_condition(context, self.spec.success[0])
        for condition in self.spec.success[1:]:
            success = success | evaluate_condition(context, condition)
        holds = torch.cat([per_object(context, c) for c in self._progress_conditions], dim=1)
        score = tracker.update(holds)
        stage = tracker.stage_index
        targets = self._stage_targets[stage.clamp(max=len(self._stage_targets) - 1)]
        fired = self.events.update(targets, gripper_closed) if self.track_events else self.events.nothing_fired
        return dict(
            success=success,
            fail=torch.zeros_like(success),
            score=torch.where(success, 1.0, score),
            progress=torch.where(success, 1.0, tracker.progress()),
            stage=stage.clone(),
            **{f"event_{kind}": flag for kind, flag in fired.items()},
        )
