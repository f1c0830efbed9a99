"""DroidObservation: what a DROID policy client receives, with ManiSkill's leading num_envs dimension kept."""

import numpy as np
import pytest

from robolab_ms.envs import DroidObservation, RoboLabEnv
from robolab_ms.errors import RoboLabError


def test_droid_keys_shapes_and_types(banana_env):
    env = DroidObservation(banana_env)
    obs, info = env.reset(seed=0)
    assert set(obs) == {
        "exterior_image_1_left",
        "wrist_image_left",
        "joint_position",
        "gripper_position",
        "eef_pose",
        "prompt",
    }
    for key in ("exterior_image_1_left", "wrist_image_left"):
        assert obs[key].shape == (1, 180, 320, 3) and obs[key].dtype == np.uint8
        assert obs[key].std() > 5.0
    assert obs["joint_position"].shape == (1, 7) and obs["joint_position"].dtype == np.float32
    np.testing.assert_allclose(obs["joint_position"][0], banana_env.unwrapped.robot.home_arm_qpos, atol=1e-4)
    assert obs["gripper_position"].shape == (1, 1) and obs["gripper_position"][0, 0] < 0.05
    assert obs["eef_pose"].shape == (1, 7)
    assert obs["prompt"] == info["instruction"] == "Put the banana in the bowl."
    assert env.observation_space["wrist_image_left"].shape == obs["wrist_image_left"].shape


def test_gripper_position_rises_when_closing(banana_env):
    env = DroidObservation(banana_env)
    obs, _ = env.reset(seed=0)
    action = np.array([*obs["joint_position"][0], 1.0], dtype=np.float32)
    for _ in range(12):
        obs, *_ = env.step(action)
    assert obs["gripper_position"][0, 0] > 0.9


def test_needs_images_and_the_wrist_camera():
    env = RoboLabEnv(task="BananaInBowl", obs_mode="state_dict", render_backend="cpu")
    try:
        with pytest.raises(RoboLabError, match="obs_mode='rgb'"):
            DroidObservation(env)
        obs, _ = DroidObservation(env, images=False).reset(seed=0)  # the robot's state only: nothing rendered
        assert set(obs) == {"joint_position", "gripper_position", "eef_pose", "prompt"}
        assert obs["joint_position"].shape == (1, 7) and obs["gripper_position"][0, 0] < 0.05
    finally:
        env.close()
