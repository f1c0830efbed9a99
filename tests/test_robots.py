"""Robot binding at run time: every supported robot runs the same task spec, with its own fingers and gripper."""

import gymnasium as gym
import numpy as np
import pytest
from helpers import hold_arm_action, put

from robolab_ms.agents import DEFAULT_ROBOT, ROBOT_BINDINGS
from robolab_ms.envs import RoboLabEnv
from robolab_ms.errors import UnknownNameError


@pytest.fixture(scope="module", params=sorted(ROBOT_BINDINGS))
def robot_env(request):
    env = gym.make("RoboLab-BananaInBowl-v1", robot_uids=request.param, obs_mode="state_dict", render_backend="cpu")
    yield env.unwrapped
    env.close()


def steps(env, count, gripper):
    info = None
    for _ in range(count):
        _, _, _, _, info = env.step(hold_arm_action(env, gripper))
    return info


def test_droid_is_the_default_robot(banana_env):
    assert DEFAULT_ROBOT == "droid"
    assert banana_env.unwrapped.robot.uid == "droid"
    assert banana_env.unwrapped.agent.uid == "droid"


def test_unknown_robot_names_the_supported_ones():
    with pytest.raises(UnknownNameError, match="panda"):
        RoboLabEnv(task="BananaInBowl", robot_uids="pandas", obs_mode="state_dict", render_backend="cpu")


def test_action_is_arm_targets_plus_a_gripper_value(robot_env):
    binding = robot_env.robot
    space = robot_env.single_action_space
    assert space.shape == (binding.action_dim,)
    assert (space.low[-1], space.high[-1]) == (0.0, 1.0)
    obs, _ = robot_env.reset(seed=0)
    np.testing.assert_allclose(robot_env.arm_qpos()[0].numpy(), binding.home_arm_qpos, atol=1e-4)
    assert obs["extra"]["gripper_position"].shape == (1, 1)


def test_gripper_fraction_follows_the_command(robot_env):
    robot_env.reset(seed=0)
    assert robot_env.gripper_closed_fraction().item() < 0.05
    steps(robot_env, 12, gripper=1.0)
    assert robot_env.gripper_closed_fraction().item() > 0.9
    steps(robot_env, 12, gripper=0.0)
    assert robot_env.gripper_closed_fraction().item() < 0.1


def test_finger_links_reach_the_predicates(robot_env):
    names = [link.name for link in robot_env.eval_context.finger_links]
    assert names == list(robot_env.robot.finger_links)


def test_banana_released_in_the_bowl_succeeds_on_every_robot(robot_env):
    _, info = robot_env.reset(seed=3)
    assert not info["success"].item()
    bowl = robot_env.objects["bowl"].pose.p[0].tolist()
    put(robot_env, "banana", (bowl[0], bowl[1], 0.05))
    info = steps(robot_env, 10, gripper=0.0)
    assert info["success"].item() and info["score"].item() == 1.0
