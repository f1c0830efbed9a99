"""The `droid` agent's joint position controllers: ManiSkill's PD joint position controllers (the arm's, and the
mimic one of the gripper), whose drive targets reach the CPU simulator in one pass over the joints.

ManiSkill sets a target on the CPU simulator joint by joint, each through a tensor conversion of its own: about a
quarter of what the controllers cost in a control step (benchmarks/drive_targets_cost.py). These controllers write
the same float32 numbers to the same joints (the simulation is unchanged, bit for bit: tests/test_controllers.py),
and leave the GPU simulator to ManiSkill.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from mani_skill.agents.controllers import (
    PDJointPosController,
    PDJointPosControllerConfig,
    PDJointPosMimicController,
    PDJointPosMimicControllerConfig,
)


def _write_cpu_drive_targets(controller: PDJointPosController, targets: torch.Tensor) -> None:
    """Set each of the controller's joints' drive target on the CPU simulator (one environment): targets (1, J)."""
    for joint, target in zip(controller.joints, targets[0].tolist(), strict=True):
        joint._objs[0].set_drive_target(target)


class JointPosController(PDJointPosController):
    """ManiSkill's PD joint position controller, its CPU drive targets written in one pass."""

    def set_drive_targets(self, targets: torch.Tensor) -> None:
        if self.scene.gpu_sim_enabled:
            super().set_drive_targets(targets)
        else:
            _write_cpu_drive_targets(self, targets)


class MimicJointPosController(PDJointPosMimicController):
    """ManiSkill's PD joint position controller with mimic joints, its CPU drive targets written in one pass."""

    def set_drive_targets(self, targets: torch.Tensor) -> None:
        if self.scene.gpu_sim_enabled:
            super().set_drive_targets(targets)
        else:
            _write_cpu_drive_targets(self, targets)


@dataclass
class JointPosControllerConfig(PDJointPosControllerConfig):
    controller_cls = JointPosController


@dataclass
class MimicJointPosControllerConfig(PDJointPosMimicControllerConfig):
    controller_cls = MimicJointPosController
