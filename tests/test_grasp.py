"""Grasping with the DROID robot: joint targets from inverse kinematics pick objects up and lift them 10 cm.

Inverse kinematics uses the robot's Pinocchio model (SAPIEN); the environment only ever receives 8-D DROID actions
(7 absolute joint targets + gripper), as a policy would send them.
"""

from pathlib import Path

import numpy as np
import pytest
import sapien

from robolab_ms.envs import RoboLabEnv
from robolab_ms.tasks.condition import Condition
from robolab_ms.tasks.predicates import PREDICATES, per_object

GRASP_LAB = Path(__file__).parent / "fixtures" / "GraspLab.yaml"
LIFT = 0.10  # m


@pytest.fixture(scope="module")
def env():
    env = RoboLabEnv(task=str(GRASP_LAB), obs_mode="state_dict", render_backend="cpu")
    yield env
    env.close()


class JointTargets:
    """Arm joint targets that put the TCP at a position, keeping the home orientation (fingers down)."""

    def __init__(self, env: RoboLabEnv) -> None:
        robot = env.agent.robot
        self.model = robot._objs[0].create_pinocchio_model()
        self.tcp_index = [link.name for link in robot.get_links()].index(env.agent.tcp.name)
        self.arm = env._arm_joint_index.numpy()
        self.mask = np.zeros(robot.max_dof, dtype=int)
        self.mask[self.arm] = 1
        self.down = env.agent.tcp.pose.sp.q  # at the home pose the fingers point straight down
        self.qpos = robot.get_qpos()[0].numpy().astype(np.float64)

    def __call__(self, position) -> np.ndarray:
        target = sapien.Pose(np.asarray(position, dtype=np.float64), self.down)
        qpos, ok, error = self.model.compute_inverse_kinematics(
            self.tcp_index, target, initial_qpos=self.qpos, active_qmask=self.mask, max_iterations=200
        )
        assert ok, f"no IK solution for {position} (error {error})"
        self.qpos = np.asarray(qpos)
        return self.qpos[self.arm]


def move(env, path: list[np.ndarray], gripper: float, settle: int = 0) -> None:
    """Send each arm target of `path` for one control step, then hold the last for `settle` steps."""
    for arm in path + [path[-1]] * settle:
        env.step(np.array([*arm, gripper], dtype=np.float32))


def line(ik: JointTargets, start, end, steps: int) -> list[np.ndarray]:
    return [ik(start + (end - start) * (i + 1) / steps) for i in range(steps)]


@pytest.mark.parametrize("name", ["mug", "can", "banana", "block"])
def test_droid_grasps_and_lifts_without_slipping(env, name):
    env.reset(seed=0)
    actor = env.objects[name]
    bounds = env.eval_context.entries[name].bounds  # object frame; the scene places objects unrotated
    centre = actor.pose.p[0].numpy() + bounds.mean(axis=0)
    top = actor.pose.p[0, 2].item() + bounds[1, 2]
    grasp = np.array([centre[0], centre[1], max(top - 0.03, centre[2])])
    above = grasp + [0.0, 0.0, 0.12]
    ik = JointTargets(env)
    start = env.agent.tcp.pose.p[0].numpy()
    move(env, line(ik, start, above, 20), gripper=0.0)
    move(env, line(ik, above, grasp, 12), gripper=0.0, settle=4)
    move(env, [ik(grasp)], gripper=1.0, settle=10)
    assert env.gripper_closed_fraction().item() < 0.95, "the gripper closed on nothing"
    held = (actor.pose.p - env.agent.tcp.pose.p)[0].numpy()
    z_before = actor.pose.p[0, 2].item()
    move(env, line(ik, grasp, grasp + [0.0, 0.0, LIFT], 15), gripper=1.0, settle=10)
    lifted = actor.pose.p[0, 2].item() - z_before
    slip = np.linalg.norm((actor.pose.p - env.agent.tcp.pose.p)[0].numpy() - held)
    assert lifted > LIFT - 0.01, f"{name} rose only {lifted:.3f} m"
    assert slip < 0.01, f"{name} slipped {slip:.3f} m in the hand"
    env.eval_context.refresh(env.elapsed_steps)
    info = PREDICATES["picked_up"]
    picked = Condition("picked_up", (name,), dict(info.references), params=dict(info.params))
    assert per_object(env.eval_context, picked)[0].tolist() == [True]
