"""Episode events: wrong grasps, collisions, drops, bumps ... recorded with step, type and object.

Each event type is a per-object (or per-gripper) condition evaluated every control step; an event fires on the
step its condition becomes true and re-arms once the condition clears, so a lasting situation is recorded once.
Targets are the objects of the current subtask stage; everything else in the task's contact objects is a
non-target. Thresholds have RoboLab's defaults and can be changed per task (`events:` in the task spec).
"""

from __future__ import annotations


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
EVENT_TYPES = (
    "wrong_object_grasped", "gripper_hit_table", "gripper_fully_closed", "object_bumped", "object_moved",
    "object_out_of_scene", "target_dropped", "gripper_hit_object", "multiple_objects_grasped", "object_tipped_over",
)  # fmt: skip
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
        self.previous = {kind: torch.zeros(self.num_envs, count if kind != "gripper" else 1, dtype=torch.bool,
                                           device=self.device) for kind in (*EVENT_TYPES, "touching")}  # fmt: skip
        self.log: list[list[dict]] = [[] for _ in range(self.num_envs)]
        self.centre = torch.tensor(SCENE_CENTRE, device=self.device)

    def reset(self, env_idx: torch.Tensor) -> None:
        """Remember where every object starts, and forget the events of the environments that restart."""
        positions, ups = self._positions_and_ups()
        self.start_position[env_idx] = positions[env_idx]
        self.start_up[env_idx] = ups[env_idx]
        for previous in self.previous.values():
            previous[env_idx] = False
        for index in env_idx.tolist():
            self.log[index] = []

    def _positions_and_ups(self) -> tuple[torch.Tensor, torch.Tensor]:
        positions = self.ctx.all_centres()[:, self.columns]
        ups = self.ctx.all_poses()[1][:, self.columns, :, 2]
        return positions, ups

    def update(self, targets: torch.Tensor, closed: torch.Tensor) -> dict[str, torch.Tensor]:
        """One control step. `targets`: (E, O) bool, the current stage's objects; `closed`: (E,) gripper closed
        fraction in [0, 1]. Returns, per event type, whether it fired in each environment (E,)."""
        ctx, limits = self.ctx, self.thresholds
        touching = ctx.gripper_forces(self.objects) > CONTACT_FORCE_N
        positions, ups = self._positions_and_ups()
        moved = torch.linalg.norm(positions - self.start_position, dim=-1)
        turned = torch.arccos((ups * self.start_up).sum(-1).clamp(-1.0, 1.0))
        others = ~targets
        conditions = {
            "wrong_object_grasped": touching & others & (closed >= limits["wrong_grasp_closed"])[:, None],
            "gripper_hit_table": (ctx.contact_force(GRIPPER, TABLE) > CONTACT_FORCE_N)[:, None],
            "gripper_fully_closed": (closed >= limits["fully_closed"])[:, None],
            "object_bumped": others & (moved >= limits["bump_distance"]) & (moved < limits["move_distance"]),
            "object_moved": others & (moved >= limits["move_distance"]),
            "object_out_of_scene": ((positions - self.centre).abs() > limits["scene_half_size"]).any(dim=-1),
            "target_dropped": targets & self.previous["touching"] & ~touching,
            "gripper_hit_object": touching & others,
            "multiple_objects_grasped": (touching.sum(dim=1) >= 2)[:, None],
            "object_tipped_over": turned > limits["tip_angle"],
        }
        self.previous["touching"] = touching
        fired = {}
        for kind, now in conditions.items():
            rising = now & ~self.previous[kind]
            self.previous[kind] = now
            fired[kind] = rising.any(dim=1)
            if fired[kind].any():
                self._record(kind, rising)
        return fired

    def _record(self, kind: str, rising: torch.Tensor) -> None:
        steps = self.ctx.elapsed_steps.tolist()
        for env, column in rising.nonzero().tolist():
            subject = self.objects[column] if rising.shape[1] == len(self.objects) else (
                TABLE if kind == "gripper_hit_table" else GRIPPER)  # fmt: skip
            self.log[env].append({"step": int(steps[env]), "type": kind, "object": subject})


