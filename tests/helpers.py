"""Helpers shared by the physics tests."""

from pathlib import Path

import numpy as np
import torch

FIXTURES = Path(__file__).parent / "fixtures"
LAB = FIXTURES / "PredicateLab.yaml"


def put(env, name, xyz, quat=(1.0, 0.0, 0.0, 0.0)):
    """Teleport a scene object and stop it."""
    actor = env.objects[name]
    pose = actor.pose
    actor.set_pose(type(pose).create_from_pq(torch.tensor([xyz], dtype=torch.float32), torch.tensor([quat])))
    actor.set_linear_velocity(torch.zeros(1, 3))
    actor.set_angular_velocity(torch.zeros(1, 3))


def hold_arm_action(env, gripper: float) -> np.ndarray:
    """An action that keeps the arm where it is, with this gripper command."""
    return np.concatenate([env.arm_qpos()[0].numpy(), [gripper]]).astype(np.float32)
