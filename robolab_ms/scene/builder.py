"""RoboLabSceneBuilder: the ManiSkill SceneBuilder for scene files (see robolab_ms.scene for the format)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sapien
import torch
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.utils.building.ground import build_ground
from mani_skill.utils.scene_builder import SceneBuilder
from mani_skill.utils.structs import Actor
from mani_skill.utils.structs.pose import Pose

from robolab_ms.catalog import Catalog, CatalogObject
from robolab_ms.catalog.procedural import Part
from robolab_ms.scene.backgrounds import load_looks
from robolab_ms.scene import TABLE_CENTER_XY, TABLE_HEIGHT, SceneSpec, quat_multiply, resting_height, yaw_quat


class RoboLabSceneBuilder(SceneBuilder):
    """Builds a table, a robot pedestal and the scene's catalog objects; places objects each episode."""

    def __init__(self, env: BaseEnv, spec: SceneSpec, catalog: Catalog) -> None:
        super().__init__(env, robot_init_qpos_noise=0.0)
        self.spec = spec
        self.catalog = catalog
        self.objects: dict[str, Actor] = {}

    def build(self, build_config_idxs: list[int] | None = None) -> None:
        length, width = self.spec.table_size
        table = self.scene.create_actor_builder()
        half = [length / 2, width / 2, TABLE_HEIGHT / 2]
        table.add_box_collision(half_size=half)
        table.add_box_visual(half_size=half, material=self._table_render_material())
        table.initial_pose = sapien.Pose(p=[TABLE_CENTER_XY[0], TABLE_CENTER_XY[1], -TABLE_HEIGHT / 2])
        self.table = table.build_kinematic(name="table")
        self.table_entry = table_entry(self.spec)

        pedestal = self.scene.create_actor_builder()
        pedestal_half = [0.15, 0.15, TABLE_HEIGHT / 2]
        pedestal.add_box_collision(half_size=pedestal_half)
        pedestal.add_box_visual(half_size=pedestal_half, material=sapien.render.RenderMaterial(
            base_color=[0.2, 0.2, 0.22, 1.0]))
        pedestal.initial_pose = sapien.Pose(p=[-0.08, 0, -TABLE_HEIGHT / 2 - 0.001])
        self.pedestal = pedestal.build_kinematic(name="robot_pedestal")
        self.ground = build_ground(self.scene, altitude=-TABLE_HEIGHT)

        if self.spec.background is not None:
            environment_map = str(load_looks().background(self.spec.background).path())
            for sub_scene in self.scene.sub_scenes:
                sub_scene.set_environment_map(environment_map)

        for placement in self.spec.objects:
            entry = self.catalog[placement.asset]
            z = resting_height(entry.points, placement.tilt) + 0.002
            pose = sapien.Pose(p=[*placement.xy, z], q=quat_multiply(yaw_quat(placement.yaw), placement.tilt))
            self.objects[placement.name] = entry.build(self.scene, placement.name, pose)
        self.scene_objects = {"table": self.table, "robot_pedestal": self.pedestal, **self.objects}
        self.movable_objects = dict(self.objects)

    def _table_render_material(self) -> sapien.render.RenderMaterial:
        """The table's look: the scene's table material (a texture) or its plain colour."""
        if self.spec.table_material is None:
            return sapien.render.RenderMaterial(base_color=list(self.spec.table_rgba), roughness=0.8)
        material = load_looks().table_material(self.spec.table_material)
        render_material = sapien.render.RenderMaterial(base_color=[1.0, 1.0, 1.0, 1.0], roughness=material.roughness)
        render_material.base_color_texture = texture_from_file(str(material.path()))
        return render_material

    def initialize(self, env_idx: torch.Tensor, init_config_idxs: list[int] | None = None) -> None:
        count = len(env_idx)
        rng = self.env._batched_episode_rng[env_idx]
        for placement in self.spec.objects:
            entry = self.catalog[placement.asset]
            offset = rng.uniform(-self.spec.jitter_xy, self.spec.jitter_xy, size=(2,)).reshape(count, 2)
            yaw = placement.yaw + rng.uniform(-self.spec.jitter_yaw, self.spec.jitter_yaw, size=(1,)).reshape(count)
            position = np.zeros((count, 3))
            position[:, :2] = np.asarray(placement.xy) + offset
            position[:, 2] = resting_height(entry.points, placement.tilt) + 0.002
            quaternion = np.stack([quat_multiply(yaw_quat(angle), placement.tilt) for angle in yaw])
            actor = self.objects[placement.name]
            actor.set_pose(Pose.create_from_pq(
                torch.as_tensor(position, dtype=torch.float32), torch.as_tensor(quaternion, dtype=torch.float32)))
            actor.set_linear_velocity(torch.zeros((count, 3)))
            actor.set_angular_velocity(torch.zeros((count, 3)))



@lru_cache(maxsize=None)
def texture_from_file(path: str) -> sapien.render.RenderTexture2D:
    """A texture image, loaded once per process."""
    return sapien.render.RenderTexture2D(path, srgb=True)


def table_entry(spec: SceneSpec) -> CatalogObject:
    """The table as a catalog-style entry (its frame is the box centre), so predicates can treat it like an object."""
    length, width = spec.table_size
    return CatalogObject(
        name="table", object_class="furniture", description="the work table", colors=(), rgba=spec.table_rgba,
        mass=1.0, static_friction=1.0, dynamic_friction=1.0, restitution=0.0, source={"kind": "scene"},
        license="n/a", parts=(Part("box", (length / 2, width / 2, TABLE_HEIGHT / 2), (0.0, 0.0, 0.0)),),
    )  # fmt: skip
