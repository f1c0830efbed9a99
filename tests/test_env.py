"""The BananaInBowl environment: creation, determinism, stepping, cameras and success."""

import numpy as np
import pytest
import torch


def object_state(env) -> np.ndarray:
    base = env.unwrapped
    return np.concatenate([actor.pose.raw_pose[0].numpy() for actor in base.objects.values()])


def hold_still(env, steps: int):
    """Command the current arm joints with the gripper open for a number of control steps."""
    base = env.unwrapped
    action = np.concatenate([base.agent.robot.get_qpos()[0, :7].numpy(), [0.0]]).astype(np.float32)
    info = None
    for _ in range(steps):
        _, _, _, _, info = env.step(action)
    return info


def place(env, name: str, x: float, y: float, z: float):
    base = env.unwrapped
    pose = base.objects[name].pose
    base.objects[name].set_pose(type(pose).create_from_pq(torch.tensor([[x, y, z]]), pose.q))


def test_spaces_follow_droid(banana_env):
    space = banana_env.unwrapped.single_action_space
    assert space.shape == (8,)
    assert space.low[-1] == 0.0 and space.high[-1] == 1.0
    assert banana_env.unwrapped.sim_freq == 120 and banana_env.unwrapped.control_freq == 15


def test_reset_is_deterministic_per_seed(banana_env):
    banana_env.reset(seed=7)
    first = object_state(banana_env)
    banana_env.reset(seed=8)
    other = object_state(banana_env)
    banana_env.reset(seed=7)
    again = object_state(banana_env)
    np.testing.assert_array_equal(first, again)
    assert not np.allclose(first, other)


def test_random_steps_and_both_cameras_render(banana_env):
    obs, info = banana_env.reset(seed=0)
    banana_env.action_space.seed(0)
    for _ in range(5):
        obs, reward, terminated, truncated, info = banana_env.step(banana_env.action_space.sample())
    assert info["instruction"] == "Put the banana in the bowl."
    for camera in ("external_left", "wrist"):
        image = obs["sensor_data"][camera]["rgb"][0]
        assert tuple(image.shape) == (180, 320, 3)
        assert image.float().std() > 5.0, f"{camera} image is (nearly) constant"


def test_success_false_at_reset_true_when_banana_released_in_bowl(banana_env):
    _, info = banana_env.reset(seed=3)
    assert not info["success"].item()
    assert info["score"].item() == 0.0
    bowl = banana_env.unwrapped.objects["bowl"].pose.p[0].tolist()
    place(banana_env, "banana", bowl[0], bowl[1], 0.05)
    info = hold_still(banana_env, 10)
    assert info["success"].item()
    assert info["score"].item() == 1.0


def test_banana_beside_the_bowl_is_not_success(banana_env):
    banana_env.reset(seed=3)
    bowl = banana_env.unwrapped.objects["bowl"].pose.p[0].tolist()
    place(banana_env, "banana", bowl[0] - 0.16, bowl[1], 0.03)
    info = hold_still(banana_env, 10)
    assert not info["success"].item()


@pytest.mark.slow
def test_a_quiet_episode_records_no_events(banana_env):
    for seed in (0, 1, 2):
        banana_env.reset(seed=seed)
        hold_still(banana_env, 15)
        assert banana_env.unwrapped.task_evaluator.events.log[0] == [], (
            f"seed {seed}: {banana_env.unwrapped.task_evaluator.events.log[0]}"
        )
