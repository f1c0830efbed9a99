"""Episode events: wrong grasps, collisions, drops, bumps ... recorded with step, type and object.

Each event type is a per-object (or per-gripper) condition evaluated every control step; an event fires on the
step its condition becomes true and re-arms once the condition clears, so a lasting situation is recorded once.
Targets are the objects of the current subtask stage and of the stages before it; everything else in the task's
contact objects is a non-target. Thresholds have RoboLab's defaults and can be changed per task (`events:` in the task spec).
"""

from __future__ import annotations

import math

import torch

from robolab_ms.tasks.context import GRIPPER, EvalContext
from robolab_ms.tasks.predicates import CONTACT_FORCE_N, TABLE

EVENT_THRESHOLDS: dict[str, float] = {
    "wrong_grasp_closed": 0.3,  # gripper closed fraction from which touching a non-target counts as grasping it
    "fully_closed": 0.75,  # gripper closed fraction that counts as fully closed
    "bump_distance": 0.05,  # a non-target displaced at least this far (m) from its start was bumped ...
    "move_distance": 0.5,  # ... and at least this far, moved
    "scene_half_size": 1.0,  # objects must stay within this half-size (m) of the scene centre
    "tip_angle": 0.3,  # an object whose up axis turned this far (rad) from its start tipped over
}
OBJECT_EVENTS = (
    "wrong_object_grasped", "object_bumped", "object_moved", "object_out_of_scene", "target_dropped",
    "gripper_hit_object", "object_tipped_over",
)  # fmt: skip
GRIPPER_EVENTS = ("gripper_hit_table", "gripper_fully_closed", "multiple_objects_grasped")
EVENT_TYPES = OBJECT_EVENTS + GRIPPER_EVENTS
SCENE_CENTRE = (0.55, 0.0, 0.5)


class EventMonitor:
    """Detects and logs events for `num_envs` environments."""

    def __init__(self, ctx: EvalContext, objects: list[str], thresholds: dict[str, float]) -> None:
        self.ctx = ctx
        self.objects = list(objects)
        self.thresholds = {**EVENT_THRESHOLDS, **thresholds}
        self.num_envs, self.device = ctx.num_envs, ctx.device
        count = len(self.objects)
        self.columns = torch.tensor([ctx.index[name] for name in self.objects], device=self.device)
        self.start_position = torch.zeros(self.num_envs, count, 3, device=self.device)
        self.start_up = torch.zeros(self.num_envs, count, 3, device=self.device)
        self.was_touching = torch.zeros(self.num_envs, count, dtype=torch.bool, device=self.device)
        self.previous_objects = torch.zeros(
            self.num_envs, len(OBJECT_EVENTS), count, dtype=torch.bool, device=self.device
        )
        self.previous_gripper = torch.zeros(self.num_envs, len(GRIPPER_EVENTS), dtype=torch.bool, device=self.device)
        self.log: list[list[dict]] = [[] for _ in range(self.num_envs)]
        self.centre = torch.tensor(SCENE_CENTRE, device=self.device)
        nothing = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        self.nothing_fired = {f"event_{kind}": nothing for kind in EVENT_TYPES}  # what a step without events reports

    def reset(self, env_idx: torch.Tensor) -> None:
        """Remember where every object starts, and forget the events of the environments that restart."""
        positions, ups = self._positions_and_ups()
        self.start_position[env_idx] = positions[env_idx]
        self.start_up[env_idx] = ups[env_idx]
        for previous in (self.was_touching, self.previous_objects, self.previous_gripper):
            previous[env_idx] = False
        for index in env_idx.tolist():
            self.log[index] = []

    def closed_levels(self, closed: torch.Tensor) -> torch.Tensor:
        """What the events read of the gripper's closed fraction (E,): whether it reaches each threshold, (E, 2)."""
        limits = self.thresholds
        return torch.stack([closed >= limits["wrong_grasp_closed"], closed >= limits["fully_closed"]], dim=1)

    def _positions_and_ups(self) -> tuple[torch.Tensor, torch.Tensor]:
        return self.ctx.all_centres()[:, self.columns], self.ctx.all_up_axes()[:, self.columns]

    def update(self, targets: torch.Tensor, closed: torch.Tensor) -> dict[str, torch.Tensor]:
        """One control step. `targets`: (E, O) bool, the current stage's objects; `closed`: (E,) gripper closed
        fraction in [0, 1]. Returns, per event type, whether it fired in each environment (E,)."""
        ctx, limits = self.ctx, self.thresholds
        finger_contacts = ctx.gripper_forces([*self.objects, TABLE]) > CONTACT_FORCE_N  # (E, O + 1)
        touching, touching_table = finger_contacts[:, :-1], finger_contacts[:, -1]
        positions, ups = self._positions_and_ups()
        moved = torch.linalg.norm(positions - self.start_position, dim=-1)
        cos_turned = (ups * self.start_up).sum(-1)
        others = ~targets
        touching_other = touching & others
        object_now = torch.stack(
            [  # in OBJECT_EVENTS order, (E, 7, O)
                touching_other & (closed >= limits["wrong_grasp_closed"])[:, None],
                others & (moved >= limits["bump_distance"]) & (moved < limits["move_distance"]),
                others & (moved >= limits["move_distance"]),
                ((positions - self.centre).abs() > limits["scene_half_size"]).any(dim=-1),
                targets & self.was_touching & ~touching,
                touching_other,
                cos_turned < math.cos(limits["tip_angle"]),
            ],
            dim=1,
        )
        gripper_now = torch.stack(
            [  # in GRIPPER_EVENTS order, (E, 3)
                touching_table,
                closed >= limits["fully_closed"],
                touching.sum(dim=1) >= 2,
            ],
            dim=1,
        )
        object_rising = object_now & ~self.previous_objects
        gripper_rising = gripper_now & ~self.previous_gripper
        self.previous_objects, self.previous_gripper, self.was_touching = object_now, gripper_now, touching
        object_fired, gripper_fired = object_rising.any(dim=-1), gripper_rising
        if bool(object_fired.any() | gripper_fired.any()):
            self._record(object_rising, gripper_rising)
        return dict(zip(EVENT_TYPES, (*object_fired.unbind(1), *gripper_fired.unbind(1))))

    def _record(self, object_rising: torch.Tensor, gripper_rising: torch.Tensor) -> None:
        steps = self.ctx.elapsed_steps.tolist()
        for env, kind, column in object_rising.nonzero().tolist():
            self.log[env].append({"step": int(steps[env]), "type": OBJECT_EVENTS[kind], "object": self.objects[column]})
        for env, kind in gripper_rising.nonzero().tolist():
            subject = TABLE if GRIPPER_EVENTS[kind] == "gripper_hit_table" else GRIPPER
            self.log[env].append({"step": int(steps[env]), "type": GRIPPER_EVENTS[kind], "object": subject})
