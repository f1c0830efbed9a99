"""Robot: offsets of the arm's initial joint positions from the robot's home pose (LIBERO-Plus perturbs these)."""

from __future__ import annotations

from typing import Any

from robolab_ms.variations.base import Axis, Context, FieldValue, Param, Range, Uniform, stream


class RobotAxis(Axis):
    name = "robot"
    summary = "offsets of the arm's initial joint positions from home"
    params = (
        Param(
            "joints",
            "offset",
            Uniform(0.0, 0.0),
            Uniform(-0.1, 0.1),
            "offset of each arm joint",
            -1.0,
            1.0,
            unit=" rad",
        ),
    )
    shorthand = "joints"

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        return {
            f"robot_joint{i + 1}_offset": round(ranges["joints"].draw(stream(seed, self.name, f"joint{i + 1}")), 5)
            for i in range(context.arm_joints)
        }

    def initialize(self, env: Any, env_idx: Any, ranges: dict[str, Range], fields: dict[str, FieldValue]) -> None:
        """Add the offsets to the arm's home joints, within the joint limits (the fields keep what was applied)."""
        import torch

        robot = env.agent.robot
        qpos = robot.get_qpos().clone()
        limits = robot.get_qlimits()[0]  # (joints, 2)
        for i, joint in enumerate(env._arm_joint_index.tolist()):
            key = f"robot_joint{i + 1}_offset"
            target = torch.clamp(qpos[:, joint] + float(fields[key]), limits[joint, 0], limits[joint, 1])
            fields[key] = round(float(target[0] - qpos[0, joint]), 5)
            qpos[:, joint] = target
        robot.set_qpos(qpos)
