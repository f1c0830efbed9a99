"""The `droid` agent: Franka Panda + Robotiq 2F-85 as in the DROID setup (FACTS section 2).

Control mode `pd_joint_pos`: 7 absolute arm joint targets (PD stiffness 400, damping 80, DROID's effort and
velocity limits) and one gripper target, the outer knuckle angle in rad (0 open, 0.8 closed), which a mimic
controller sends to both outer knuckles. The inner knuckles and inner fingers are passive; a drive constraint per
finger closes each four-bar linkage, the way ManiSkill's own Robotiq agents do. RoboLabEnv turns DROID's gripper
value (0 open, 1 closed, > 0.5 closes) into that target.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import sapien
from mani_skill.agents.base_agent import BaseAgent, Keyframe
from mani_skill.agents.controllers import PassiveControllerConfig, deepcopy_dict
from mani_skill.agents.registration import register_agent
from mani_skill.utils.structs.pose import Pose

from robolab_ms.agents import droid_model as model
from robolab_ms.agents.controllers import JointPosControllerConfig, MimicJointPosControllerConfig

ARM_STIFFNESS = 400.0
ARM_DAMPING = 80.0
# The gripper: a stiff position drive whose torque and speed are capped, so the pads close at a Robotiq-like speed and
# squeeze with a bounded force. Each pad sits 4.3 cm (horizontally) from its outer knuckle's axis, so 2 Nm presses a
# pad with about 46 N (a 2F-85 grips with 20 to 235 N) and 1.5 rad/s closes the pads at about 13 cm/s (a 2F-85: 2 to
# 15 cm/s). Without the speed cap the pads strike the object and squeeze round ones out (issue 15, docs/validation.md).
GRIPPER_STIFFNESS = 1e5
GRIPPER_DAMPING = 2e3
GRIPPER_FORCE_LIMIT = 2.0  # Nm at each outer knuckle
GRIPPER_MAX_VELOCITY = 1.5  # rad/s at each outer knuckle
# Static and dynamic friction of the finger pads. PhysX averages the two materials of a contact, so on our objects
# (0.8 static, 0.6 dynamic) a pad grips with 2.1 / 2.0: RoboLab's pad-object friction (its objects and pads are 2.0).
PAD_FRICTION = 3.4


@register_agent()
class DroidPandaRobotiq(BaseAgent):
    """Franka Panda arm with a Robotiq 2F-85 gripper, DROID's embodiment."""

    uid = "droid"
    disable_self_collisions = True
    urdf_config = dict(
        _materials=dict(gripper=dict(static_friction=PAD_FRICTION, dynamic_friction=PAD_FRICTION, restitution=0.0)),
        link={pad: dict(material="gripper", patch_radius=0.1, min_patch_radius=0.1) for pad in model.FINGER_PAD_LINKS},
    )
    keyframes = dict(home=Keyframe(qpos=np.array([*model.DROID_HOME_ARM] + [0.0] * 6), pose=sapien.Pose()))
    arm_joint_names = list(model.ARM_JOINTS)
    gripper_joint_names = list(model.DRIVEN_GRIPPER_JOINTS)

    @cached_property
    def urdf_path(self) -> str:  # written at first use into the cache folder (see droid_model)
        return str(model.droid_urdf_path())

    @property
    def _controller_configs(self) -> dict:
        arm = JointPosControllerConfig(
            self.arm_joint_names,
            lower=None,
            upper=None,
            stiffness=ARM_STIFFNESS,
            damping=ARM_DAMPING,
            force_limit=list(model.ARM_EFFORT),
            normalize_action=False,
        )
        left, right = model.DRIVEN_GRIPPER_JOINTS
        gripper = MimicJointPosControllerConfig(
            list(model.DRIVEN_GRIPPER_JOINTS),
            lower=0.0,
            upper=model.GRIPPER_CLOSED_RAD,
            stiffness=GRIPPER_STIFFNESS,
            damping=GRIPPER_DAMPING,
            force_limit=GRIPPER_FORCE_LIMIT,
            normalize_action=False,
            mimic={right: dict(joint=left)},
        )
        passive = PassiveControllerConfig(list(model.PASSIVE_GRIPPER_JOINTS), damping=0.0, friction=0.0)
        return deepcopy_dict(dict(pd_joint_pos=dict(arm=arm, gripper=gripper, gripper_passive=passive)))

    def _after_loading_articulation(self) -> None:
        for index, name in enumerate(model.ARM_JOINTS):
            for joint in self.robot.joints_map[name]._objs:
                joint.set_max_velocity(model.ARM_VELOCITY[index])
        for name in model.DRIVEN_GRIPPER_JOINTS:
            for joint in self.robot.joints_map[name]._objs:
                joint.set_max_velocity(GRIPPER_MAX_VELOCITY)
        knuckle_anchor, finger_anchor = model.linkage_anchors()
        for side in ("left", "right"):
            knuckle = self.robot.active_joints_map[f"{side}_inner_knuckle_joint"].get_child_link()
            finger = self.robot.active_joints_map[f"{side}_inner_finger_joint"].get_child_link()
            drive = self.scene.create_drive(knuckle, sapien.Pose(knuckle_anchor), finger, sapien.Pose(finger_anchor))
            drive.set_limit_x(0, 0)
            drive.set_limit_y(0, 0)
            drive.set_limit_z(0, 0)

    def _after_init(self) -> None:
        links = self.robot.links_map
        self.finger1_link, self.finger2_link = (links[name] for name in model.FINGER_PAD_LINKS)
        self.finger_links = [links[name] for name in model.FINGER_PAD_LINKS + model.FINGER_LINKS]
        self.gripper_base_link = links[model.GRIPPER_BASE_LINK]
        self.tcp = links[model.TCP_LINK]

    @property
    def tcp_pose(self) -> Pose:
        """End-effector pose: between the finger pads, z along the fingers."""
        return self.tcp.pose
