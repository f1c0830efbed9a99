"""SceneOnlyEnv: a ManiSkill environment that builds one scene file and nothing else of a task.

For looking at scenes, timing scene builds and testing the scene builder: ManiSkill's Panda (no cameras), the
table and the scene's objects, no success conditions. Swap `scene_spec` and reset with `reconfigure` to rebuild.
"""

from __future__ import annotations

import sapien
import torch
from mani_skill.envs.sapien_env import BaseEnv

from robolab_ms.catalog import load_catalog
from robolab_ms.scene import SceneSpec
from robolab_ms.scene.builder import RoboLabSceneBuilder


class SceneOnlyEnv(BaseEnv):
    """Builds `scene` with RoboLabSceneBuilder; evaluate() reports nothing."""

    def __init__(self, scene: SceneSpec, **kwargs) -> None:
        self.scene_spec = scene
        super().__init__(robot_uids="panda", obs_mode="state_dict", reward_mode="none", render_mode=None, **kwargs)

    @property
    def _default_sensor_configs(self) -> list:
        return []

    def _load_agent(self, options: dict) -> None:
        super()._load_agent(options, sapien.Pose())

    def _load_scene(self, options: dict) -> None:
        self.builder = RoboLabSceneBuilder(self, self.scene_spec, load_catalog())
        self.builder.build()

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict) -> None:
        self.builder.initialize(env_idx)

    def evaluate(self) -> dict:
        return {}

    def _get_obs_extra(self, info: dict) -> dict:
        return {}
