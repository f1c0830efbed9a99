"""What RoboLabEnv needs to know about each robot it can run, keyed by ManiSkill agent uid.

A task spec names no robot; the environment keyword `robot_uids` picks one of `ROBOT_BINDINGS`. A binding says
which joints form the arm, the home pose, the finger links (for grasped / released / wrong-object predicates and
events), the gripper's base link (the point whose path the trajectory metrics measure), how to read the gripper's
closed fraction, and which controller value opens or closes the gripper.
Every robot takes the same action layout: absolute arm joint targets followed by one gripper value in [0, 1]
(0 open, 1 closed, above 0.5 closes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import torch

from robolab_ms.agents import droid_model
from robolab_ms.errors import UnknownNameError

DEFAULT_ROBOT = "droid"


@dataclass(frozen=True)
class RobotBinding:
    """How RoboLabEnv drives and reads one ManiSkill agent."""

    uid: str
    arm_joints: tuple[str, ...]
    home_arm_qpos: tuple[float, ...]
    finger_links: tuple[str, ...]  # every link that counts as the gripper touching something
    gripper_joints: tuple[str, ...]  # their mean position measures how far the gripper is closed
    gripper_open_qpos: float
    gripper_closed_qpos: float
    gripper_open_action: float  # controller value for "open" (the last action entry)
    gripper_closed_action: float
    wrist_mount_link: str  # the wrist camera rides on this link
    # the link the end-effector metrics follow: RoboLab's is the Robotiq gripper's base link; other robots use the
    # link their gripper is built on (docs/results.md)
    gripper_base_link: str
    # (eye, target, up) in the mount link's frame; None: DROID's wrist camera pose (robolab_ms.envs.cameras)
    wrist_look_at: tuple[tuple[float, float, float], ...] | None = None
    base_yaw: float = 0.0  # rotation of the robot base about z, rad, so that the arm faces the table (+x)
    notes: str = field(default="", compare=False)

    @property
    def action_dim(self) -> int:
        return len(self.arm_joints) + 1

    def closed_fraction(self, gripper_qpos: torch.Tensor) -> torch.Tensor:
        """Gripper closed fraction in [0, 1] (1 closed) from the gripper joints' positions: (E, J) -> (E,)."""
        span = self.gripper_closed_qpos - self.gripper_open_qpos
        return ((gripper_qpos.mean(dim=1) - self.gripper_open_qpos) / span).clamp(0.0, 1.0)

    def gripper_action(self, command: torch.Tensor) -> torch.Tensor:
        """The controller's gripper value for DROID gripper commands (> 0.5 closes): (E,) -> (E,)."""
        return torch.where(command > 0.5, self.gripper_closed_action, self.gripper_open_action)


ROBOT_BINDINGS: dict[str, RobotBinding] = {
    binding.uid: binding
    for binding in (
        RobotBinding(
            uid="droid",
            arm_joints=droid_model.ARM_JOINTS,
            home_arm_qpos=droid_model.DROID_HOME_ARM,
            finger_links=droid_model.FINGER_PAD_LINKS + droid_model.FINGER_LINKS,
            gripper_joints=droid_model.DRIVEN_GRIPPER_JOINTS,
            gripper_open_qpos=0.0,
            gripper_closed_qpos=droid_model.GRIPPER_CLOSED_RAD,
            gripper_open_action=0.0,
            gripper_closed_action=droid_model.GRIPPER_CLOSED_RAD,
            wrist_mount_link=droid_model.GRIPPER_BASE_LINK,
            gripper_base_link=droid_model.GRIPPER_BASE_LINK,
            notes="Franka Panda + Robotiq 2F-85 (DROID); 8-D action",
        ),
        RobotBinding(
            uid="panda",
            arm_joints=droid_model.ARM_JOINTS,
            home_arm_qpos=droid_model.DROID_HOME_ARM,
            finger_links=("panda_leftfinger", "panda_rightfinger"),
            gripper_joints=("panda_finger_joint1", "panda_finger_joint2"),
            gripper_open_qpos=0.04,
            gripper_closed_qpos=0.0,
            gripper_open_action=1.0,  # ManiSkill's Panda gripper controller: +1 open, -1 closed
            gripper_closed_action=-1.0,
            wrist_mount_link="panda_hand",
            gripper_base_link="panda_hand",  # the Franka hand's body, which carries both fingers
            wrist_look_at=((0.06, 0.0, 0.0), (0.0, 0.0, 0.2), (1.0, 0.0, 0.0)),  # beside the hand, along the fingers
            notes="ManiSkill's Franka Panda with the Franka hand; 8-D action",
        ),
        RobotBinding(
            uid="so100",
            arm_joints=("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"),
            home_arm_qpos=(0.0, -1.5708, 1.5708, 0.66, 0.0),
            finger_links=("Fixed_Jaw", "Moving_Jaw"),
            gripper_joints=("gripper",),
            gripper_open_qpos=0.5,
            gripper_closed_qpos=-1.1,
            gripper_open_action=0.5,  # the jaw joint's absolute target, rad
            gripper_closed_action=-1.1,
            wrist_mount_link="Fixed_Jaw",
            gripper_base_link="Fixed_Jaw",  # the gripper body: it carries the moving jaw's joint
            wrist_look_at=((0.0, -0.02, 0.06), (0.01, -0.15, 0.0), (0.0, 0.0, 1.0)),  # above the fixed jaw
            base_yaw=math.pi / 2,
            notes="TheRobotStudio SO-100 (5 joints + jaw, in mani-skill's package); 6-D action; reach about 0.4 m",
        ),
    )
}


def robot_binding(uid: str) -> RobotBinding:
    """The binding for a robot uid; an unknown uid raises UnknownNameError listing the supported ones."""
    if uid not in ROBOT_BINDINGS:
        raise UnknownNameError("robot", uid, ROBOT_BINDINGS)
    return ROBOT_BINDINGS[uid]
