"""The droid agent's joint position controllers write on the CPU simulator exactly the drive targets ManiSkill's own
controllers write, so an episode's physics is the same, bit for bit."""

import numpy as np
import pytest
import torch
from helpers import hold_arm_action
from mani_skill.agents.controllers import PDJointPosController, PDJointPosMimicController

from robolab_ms.agents.controllers import JointPosController, MimicJointPosController


def drive_targets(controller) -> np.ndarray:
    return np.array([joint._objs[0].drive_target for joint in controller.joints], dtype=np.float32).reshape(-1)


def test_the_droid_agent_uses_them(lab):
    controllers = lab.agent.controller.controllers
    assert type(controllers["arm"]) is JointPosController
    assert type(controllers["gripper"]) is MimicJointPosController


@pytest.mark.parametrize("name", ["arm", "gripper"])
def test_each_joint_gets_the_target_maniskill_would_set(lab, name):
    controller = lab.agent.controller.controllers[name]
    rng = np.random.default_rng(3)
    for _ in range(5):
        targets = torch.from_numpy(rng.uniform(-2.5, 2.5, (1, len(controller.joints))).astype(np.float32))
        PDJointPosController.set_drive_targets(controller, targets)  # ManiSkill's way: joint by joint
        expected = drive_targets(controller)
        controller.set_drive_targets(torch.zeros_like(targets))
        assert not np.array_equal(drive_targets(controller), expected)
        controller.set_drive_targets(targets)
        assert np.array_equal(drive_targets(controller), expected)
        assert np.array_equal(expected, targets[0].numpy())


def _random_episode(env, steps: int) -> list[np.ndarray]:
    """Reset at seed 0, then step random arm and gripper commands: the robot's and the objects' states per step."""
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    home = hold_arm_action(env, 0.0)
    states = []
    for _ in range(steps):
        action = home.copy()
        action[..., :-1] += rng.uniform(-0.4, 0.4, action[..., :-1].shape).astype(np.float32)
        action[..., -1] = rng.uniform(0.0, 1.0)
        env.step(action)
        states.append(env.get_state().numpy().copy())
    return states


def test_an_episode_is_the_same_bit_for_bit_as_with_maniskills_controllers(lab, monkeypatch):
    ours = _random_episode(lab, 40)
    monkeypatch.setattr(JointPosController, "set_drive_targets", PDJointPosController.set_drive_targets)
    monkeypatch.setattr(MimicJointPosController, "set_drive_targets", PDJointPosMimicController.set_drive_targets)
    theirs = _random_episode(lab, 40)
    assert not np.array_equal(ours[0], ours[-1])  # the arm moved
    for step, (mine, maniskill) in enumerate(zip(ours, theirs, strict=True)):
        assert np.array_equal(mine, maniskill), f"step {step}"
