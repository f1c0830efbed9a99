"""Steps per second of a RoboLab environment against a bare ManiSkill environment with the same scene and cameras.

The bare environment is a plain BaseEnv with the same robot (droid), the same scene built by RoboLabSceneBuilder and
the same two 320x180 cameras, but no task logic, DROID action mapping or extra observations. Timed blocks of the two
alternate in one process; the script prints the median steps per second and the median ratio (target: >= 0.85).

    .venv/bin/python benchmarks/camera_step_cost.py [--steps 60] [--rounds 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.utils.structs.types import SimConfig

from robolab_ms.agents import robot_binding
from robolab_ms.catalog import load_catalog
from robolab_ms.envs import RoboLabEnv
from robolab_ms.envs import cameras
from robolab_ms.envs.robolab_env import SIM_HZ
from robolab_ms.scene.builder import RoboLabSceneBuilder
from robolab_ms.tasks.spec import CONTROL_HZ, load_task

TASK = "BananaInBowl"


class BareEnv(BaseEnv):
    """The same scene, robot and cameras in a plain ManiSkill environment."""

    SUPPORTED_ROBOTS = ["droid"]
    SUPPORTED_REWARD_MODES = ("none",)

    def __init__(self, *args, **kwargs):
        self.spec = load_task(TASK)
        self.binding = robot_binding("droid")
        super().__init__(*args, robot_uids="droid", control_mode="pd_joint_pos", **kwargs)

    @property
    def _default_sim_config(self):
        return SimConfig(sim_freq=SIM_HZ, control_freq=CONTROL_HZ)

    @property
    def _default_sensor_configs(self):
        mount = self.agent.robot.links_map[self.binding.wrist_mount_link]
        return cameras.policy_camera_configs(cameras.DEFAULT_CAMERAS, 320, 180, mount, cameras.wrist_pose(self.binding))

    def _load_scene(self, options):
        self.scene_builder = RoboLabSceneBuilder(self, self.spec.scene, load_catalog())
        self.scene_builder.build()

    def _initialize_episode(self, env_idx, options):
        with torch.device(self.device):
            self.scene_builder.initialize(env_idx)
            self.agent.reset(torch.tensor([[*self.binding.home_arm_qpos] + [0.0] * 6]).repeat(len(env_idx), 1))

    def evaluate(self):
        return {}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=60, help="control steps per timed block")
    parser.add_argument("--rounds", type=int, default=5, help="timed blocks of each kind")
    args = parser.parse_args()

    ours = RoboLabEnv(task=TASK, obs_mode="rgb", render_backend="cpu")
    bare = BareEnv(obs_mode="rgb", render_backend="cpu", reward_mode="none")
    arm = list(robot_binding("droid").home_arm_qpos)
    actions = {id(ours): np.array([*arm, 0.0], dtype=np.float32), id(bare): np.array([*arm, 0.0], dtype=np.float32)}

    def block(env) -> float:
        env.reset(seed=0)
        start = time.perf_counter()
        for _ in range(args.steps):
            env.step(actions[id(env)])
        return args.steps / (time.perf_counter() - start)

    block(ours), block(bare)  # warm-up
    ratios, ours_sps, bare_sps = [], [], []
    for _ in range(args.rounds):
        a, b = block(ours), block(bare)
        ours_sps.append(a), bare_sps.append(b), ratios.append(a / b)
    print(f"task {TASK}, robot droid, cameras external_left + wrist at 320x180, {args.steps} steps x {args.rounds} rounds")
    print(f"RoboLab env:       median {statistics.median(ours_sps):.1f} steps/s")
    print(f"bare ManiSkill env: median {statistics.median(bare_sps):.1f} steps/s")
    print(f"ratio (target >= 0.85): median {statistics.median(ratios):.3f}  (min {min(ratios):.3f}, max {max(ratios):.3f})")


if __name__ == "__main__":
    main()
