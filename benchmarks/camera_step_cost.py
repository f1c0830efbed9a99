"""Steps per second of a RoboLab environment against a bare ManiSkill environment with the same scene and cameras,
and what the DROID-like look (room, textures, shadows) costs against the flat look it replaced.

The bare environment is a plain BaseEnv with the same robot (droid), the same scene built by RoboLabSceneBuilder,
the same lights and the same two 320x180 cameras, but no task logic, DROID action mapping or extra observations.
The old-look environment is the bare one as scenes looked before: ManiSkill's grid ground, no room, flat colours,
ManiSkill's default lights without shadows. Timed blocks of the three alternate in one process; the script prints
the median steps per second, the median ratio ours / bare (target: >= 0.85) and the new look's cost per step.

    .venv/bin/python benchmarks/camera_step_cost.py [--steps 60] [--rounds 5] [--shadow-map 1024]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import sapien
import torch
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.utils.structs.types import SimConfig

import robolab_ms.catalog.schema as catalog_schema
from robolab_ms.agents import robot_binding
from robolab_ms.catalog import load_catalog
from robolab_ms.catalog.appearance import Look
from robolab_ms.envs import RoboLabEnv, cameras
from robolab_ms.physics import SIM_HZ
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

    def _load_lighting(self, options):
        self.scene_builder.build_lighting()

    def _initialize_episode(self, env_idx, options):
        with torch.device(self.device):
            self.scene_builder.initialize(env_idx)
            self.agent.reset(torch.tensor([[*self.binding.home_arm_qpos] + [0.0] * 6]).repeat(len(env_idx), 1))

    def evaluate(self):
        return {}


class OldLookEnv(BareEnv):
    """The bare environment with the look scenes had before: grid ground, black void, flat colours, no shadows."""

    def _load_scene(self, options):
        from mani_skill.utils.building.ground import build_ground

        from robolab_ms.scene import TABLE_HEIGHT

        def flat(look, face=0):
            return sapien.render.RenderMaterial(base_color=[*look.rgb, 1.0], roughness=0.6)

        builder = RoboLabSceneBuilder(self, self.spec.scene, load_catalog())
        builder._build_floor = lambda: build_ground(self.scene, altitude=-TABLE_HEIGHT)
        builder._build_backdrop = lambda: None
        builder._table_render_material = lambda: flat(Look("plastic", (0.45, 0.3, 0.15), 0.8))
        original = catalog_schema.render_material
        catalog_schema.render_material = flat  # objects: flat colours, as before
        try:
            builder.build()
        finally:
            catalog_schema.render_material = original
        for sub_scene in self.scene.sub_scenes:
            sub_scene.render_system.cubemap = None
        self.scene_builder = builder

    def _load_lighting(self, options):
        BaseEnv._load_lighting(self, options)  # ManiSkill's ambient light and two directional lights, no shadows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=60, help="control steps per timed block")
    parser.add_argument("--rounds", type=int, default=5, help="timed blocks of each kind")
    parser.add_argument("--shadow-map", type=int, default=None, help="shadow map size (default: the builder's)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.steps, args.rounds = 2, 1
    if args.shadow_map:
        RoboLabSceneBuilder.shadow_map_size = args.shadow_map

    ours = RoboLabEnv(task=TASK, obs_mode="rgb", render_backend="cpu")
    bare = BareEnv(obs_mode="rgb", render_backend="cpu", reward_mode="none")
    old = OldLookEnv(obs_mode="rgb", render_backend="cpu", reward_mode="none")
    arm = list(robot_binding("droid").home_arm_qpos)
    actions = {id(env): np.array([*arm, 0.0], dtype=np.float32) for env in (ours, bare, old)}

    def block(env) -> float:
        env.reset(seed=0)
        start = time.perf_counter()
        for _ in range(args.steps):
            env.step(actions[id(env)])
        return args.steps / (time.perf_counter() - start)

    block(ours), block(bare), block(old)  # warm-up
    ratios, look_ratios, ours_sps, bare_sps, old_sps = [], [], [], [], []
    for _ in range(args.rounds):
        a, b, c = block(ours), block(bare), block(old)
        ours_sps.append(a), bare_sps.append(b), old_sps.append(c), ratios.append(a / b), look_ratios.append(b / c)
    median = statistics.median
    print(
        f"task {TASK}, robot droid, cameras external_left + wrist at 320x180, {args.steps} steps x {args.rounds} rounds,"
        f" shadow map {RoboLabSceneBuilder.shadow_map_size} px"
    )
    print(f"RoboLab env:                  median {median(ours_sps):.1f} steps/s")
    print(f"bare ManiSkill env, same look: median {median(bare_sps):.1f} steps/s")
    print(f"bare env, old flat look:       median {median(old_sps):.1f} steps/s")
    print(
        f"ratio ours / bare (target >= 0.85): median {median(ratios):.3f}  (min {min(ratios):.3f}, max {max(ratios):.3f})"
    )
    cost = 1000 / median(bare_sps) - 1000 / median(old_sps)
    print(
        f"the new look (room, textures, shadows) vs the old: {median(look_ratios):.3f} x the old step rate, "
        f"{cost:+.1f} ms per step"
    )


if __name__ == "__main__":
    main()
