"""RoboLabSceneBuilder: the ManiSkill SceneBuilder for scene files (see robolab_ms.scene for the format)."""

from __future__ import annotations

import numpy as np
import sapien
import torch
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.utils.building.actor_builder import ActorBuilder
from mani_skill.utils.scene_builder import SceneBuilder
from mani_skill.utils.structs import Actor
from mani_skill.utils.structs.pose import Pose

from robolab_ms.catalog import Catalog, CatalogObject
from robolab_ms.catalog.appearance import (
    Look,
    cylinder_mesh,
    panorama_sphere,
    plane_mesh,
    render_material,
    scene_renders,
    texture_from_file,
    visual_mesh_builder,
)
from robolab_ms.catalog.procedural import Part, quat_multiply, yaw_quat
from robolab_ms.scene.backgrounds import lighting_cubemap, load_looks, panorama_texture
from robolab_ms.scene.jitter import JitterSampler
from robolab_ms.scene.room import LightSetup, table_material
from robolab_ms.scene.spec import (
    ROBOT_PEDESTAL_CENTER,
    ROBOT_PEDESTAL_HALF_SIZE,
    TABLE_CENTER_XY,
    TABLE_HEIGHT,
    SceneSpec,
)

TABLE_TOP_THICKNESS = 0.035
ROOM_RADIUS = 7.0  # m: half the floor's size; the panorama sphere is just outside it
PANORAMA_EYE_HEIGHT = 1.5  # m above the floor: where the panorama's camera stood
SHADOW_HALF_SIZE = 1.0  # m: the key light's shadow covers the table and the robot
SHADOW_MAP_SIZE = 1024


class RoboLabSceneBuilder(SceneBuilder):
    """Builds the room (floor, panorama backdrop, lights), the table, the robot's stand and the scene's catalog
    objects; places objects each episode. In a scene that cannot render (`render_backend="none"`) only their
    collision shapes are built: no backdrop, environment map, lights, materials or textures."""

    shadow_map_size = SHADOW_MAP_SIZE  # px, of the key light's shadow map

    def __init__(self, env: BaseEnv, spec: SceneSpec, catalog: Catalog) -> None:
        super().__init__(env, robot_init_qpos_noise=0.0)
        self.spec = spec
        self.catalog = catalog
        self.objects: dict[str, Actor] = {}
        looks = load_looks()
        self.background = looks.background(spec.background or looks.default_background)
        self.table_material: str | None = None  # a table material in place of the scene's (set before build)
        self.light = LightSetup()  # the room's light (set before build)
        self._jitter: JitterSampler | None = None  # made on the first episode

    def build(self, build_config_idxs: list[int] | None = None) -> None:
        self.renders = scene_renders(self.scene)
        self.table = self._build_table()
        self.table_entry = table_entry(self.spec)
        self.pedestal = self._build_stand()
        self.ground = self._build_floor()
        self.backdrop = self._build_backdrop() if self.renders else None
        if self.renders:
            light, name = self.light.environment, self.background.name
            environment_map = lighting_cubemap(name, light) if light != 1.0 else lighting_cubemap(name)
            for sub_scene in self.scene.sub_scenes:
                sub_scene.set_environment_map(environment_map)

        for placement in self.spec.objects:
            entry = self.catalog[placement.asset]
            pose = sapien.Pose(p=[*placement.xy, placement.z], q=quat_multiply(yaw_quat(placement.yaw), placement.tilt))
            self.objects[placement.name] = entry.build(self.scene, placement.name, pose)
        self.scene_objects = {"table": self.table, "robot_pedestal": self.pedestal, **self.objects}
        self.movable_objects = dict(self.objects)

    # ------------------------------------------------------------------------------------------------ the room
    def _build_table(self) -> Actor:
        """A table top on four legs; its collision is one box from the floor to the top (z = 0)."""
        length, width = self.spec.table_size
        table = visual_mesh_builder(self.scene)
        half = [length / 2, width / 2, TABLE_HEIGHT / 2]
        table.add_box_collision(half_size=half)
        if self.renders:
            self._add_table_visuals(table, half)
        table.initial_pose = sapien.Pose(p=[TABLE_CENTER_XY[0], TABLE_CENTER_XY[1], -TABLE_HEIGHT / 2])
        return table.build_kinematic(name="table")

    def _add_table_visuals(self, table: ActorBuilder, half: list[float]) -> None:
        """The top in the table material, metal legs and a wooden apron under the top's long edges."""
        top = self._table_render_material()
        table.add_box_visual(
            pose=sapien.Pose(p=[0, 0, half[2] - TABLE_TOP_THICKNESS / 2]),
            half_size=[half[0], half[1], TABLE_TOP_THICKNESS / 2],
            material=top,
        )
        legs = render_material(Look("metal", (0.55, 0.55, 0.57), 0.35, 0.9))
        leg_half = (TABLE_HEIGHT - TABLE_TOP_THICKNESS) / 2
        for sx in (-1, 1):
            for sy in (-1, 1):
                position = [sx * (half[0] - 0.06), sy * (half[1] - 0.06), -half[2] + leg_half]
                table.add_visual_mesh(
                    cylinder_mesh(0.022, leg_half), legs, sapien.Pose(p=position, q=[0.7071068, 0, 0.7071068, 0])
                )
        apron = render_material(Look("wood", (0.35, 0.25, 0.16), 0.6))
        for sign in (-1, 1):
            table.add_box_visual(
                pose=sapien.Pose(p=[0, sign * (half[1] - 0.07), half[2] - TABLE_TOP_THICKNESS - 0.04]),
                half_size=[half[0] - 0.08, 0.01, 0.04],
                material=apron,
            )

    def _build_stand(self) -> Actor:
        """The robot's stand: a powder-coated steel column from the floor to the robot base, on a wider foot."""
        stand = self.scene.create_actor_builder()
        stand_half = list(ROBOT_PEDESTAL_HALF_SIZE)
        stand.add_box_collision(half_size=stand_half)
        if self.renders:
            coat = render_material(Look("plastic", (0.16, 0.16, 0.17), 0.5, 0.3))
            stand.add_box_visual(half_size=stand_half, material=coat)
            plate = render_material(Look("dark_metal", (0.7, 0.7, 0.72), 0.4, 0.9))
            stand.add_box_visual(
                pose=sapien.Pose(p=[0, 0, TABLE_HEIGHT / 2 - 0.005]), half_size=[0.16, 0.16, 0.006], material=plate
            )
            stand.add_box_visual(
                pose=sapien.Pose(p=[0, 0, -TABLE_HEIGHT / 2 + 0.01]), half_size=[0.25, 0.25, 0.01], material=plate
            )
        stand.initial_pose = sapien.Pose(p=list(ROBOT_PEDESTAL_CENTER))
        return stand.build_kinematic(name="robot_pedestal")

    def _build_floor(self) -> Actor:
        """The room's floor: a collision plane at z = -TABLE_HEIGHT with the background's floor texture."""
        floor = visual_mesh_builder(self.scene)
        floor.add_plane_collision(sapien.Pose(q=[0.7071068, 0, -0.7071068, 0]))
        if self.renders:
            floor_look = load_looks().floor(self.background.floor)
            material = sapien.render.RenderMaterial(base_color=[1.0, 1.0, 1.0, 1.0], roughness=floor_look.roughness)
            material.base_color_texture = texture_from_file(str(floor_look.path()))
            size = 2 * ROOM_RADIUS
            floor.add_visual_mesh(plane_mesh(size, size, floor_look.tile), material)
        floor.initial_pose = sapien.Pose(p=[TABLE_CENTER_XY[0], 0, -TABLE_HEIGHT])
        return floor.build_static(name="floor")

    def _build_backdrop(self) -> Actor:
        """The background's panorama on a large sphere around the room, shown as it is (emissive, unlit)."""
        material = sapien.render.RenderMaterial(base_color=[0.0, 0.0, 0.0, 1.0], roughness=1.0, specular=0.0)
        material.emission_texture = panorama_texture(self.background.name)
        material.emission = [1.0, 1.0, 1.0, 1.0]
        backdrop = visual_mesh_builder(self.scene)
        backdrop.add_visual_mesh(panorama_sphere(ROOM_RADIUS + 0.5), material)
        backdrop.initial_pose = sapien.Pose(p=[TABLE_CENTER_XY[0], 0, -TABLE_HEIGHT + PANORAMA_EYE_HEIGHT])
        return backdrop.build_static(name="room_backdrop")

    def build_lighting(self, shadows: bool = True, shadow_map_size: int | None = None) -> None:
        """The room's light: a shadow-casting key light from above the table, the environment map and a little
        ambient light. Called by the environment in place of ManiSkill's default lighting; nothing without a
        render system."""
        if not scene_renders(self.scene):
            return
        shadow_map_size = shadow_map_size or self.shadow_map_size
        self.scene.set_ambient_light(list(self.light.ambient))
        self.scene.add_directional_light(
            list(self.light.key_direction),
            list(self.light.key_color),
            shadow=shadows,
            position=[TABLE_CENTER_XY[0], TABLE_CENTER_XY[1], 0.0],
            shadow_scale=SHADOW_HALF_SIZE,
            shadow_near=-2.0,
            shadow_far=2.0,
            shadow_map_size=shadow_map_size,
        )

    def _table_render_material(self) -> sapien.render.RenderMaterial:
        """The table top's look: the scene's table material, the default wood for a brown table, or a laminate in
        the scene's table colour."""
        looks = load_looks()
        name = self.table_material or table_material(self.spec)
        if name is None:
            return render_material(Look("painted_wood", tuple(self.spec.table_rgba[:3]), 0.5))
        material = looks.table_material(name)
        render = sapien.render.RenderMaterial(base_color=[*material.tint, 1.0], roughness=material.roughness)
        render.base_color_texture = texture_from_file(str(material.path()))
        return render

    def initialize(self, env_idx: torch.Tensor, init_config_idxs: list[int] | None = None) -> None:
        """Each object at its nominal place, moved and turned by the scene's jitter (neighbours kept apart, see
        robolab_ms.scene.jitter); an object resting on another moves and turns with the object at the bottom of its
        pile, so the pile stays as the scene file built it."""
        count = len(env_idx)
        rng = self.env._batched_episode_rng[env_idx]
        if self._jitter is None:
            self._jitter = JitterSampler(self.spec, self.catalog)
        draws = [self._jitter.draw(rng[i]) for i in range(count)]
        jitter = {
            placement.name: (np.stack([draw[0][index] for draw in draws]), np.array([draw[1][index] for draw in draws]))
            for index, placement in enumerate(self.spec.objects)
        }
        for placement in self.spec.objects:
            if placement.fixture:
                continue  # a fixture (kinematic) stays where build() put it
            base = self.spec.placement(self.spec.base(placement.name))
            offset, turn = jitter[base.name]
            arm = np.asarray(placement.xy) - np.asarray(base.xy)
            cos, sin = np.cos(turn), np.sin(turn)
            position = np.zeros((count, 3))
            position[:, 0] = base.xy[0] + cos * arm[0] - sin * arm[1] + offset[:, 0]
            position[:, 1] = base.xy[1] + sin * arm[0] + cos * arm[1] + offset[:, 1]
            position[:, 2] = placement.z
            quaternion = np.stack([quat_multiply(yaw_quat(angle), placement.tilt) for angle in placement.yaw + turn])
            actor = self.objects[placement.name]
            actor.set_pose(
                Pose.create_from_pq(
                    torch.as_tensor(position, dtype=torch.float32), torch.as_tensor(quaternion, dtype=torch.float32)
                )
            )
            actor.set_linear_velocity(torch.zeros((count, 3)))
            actor.set_angular_velocity(torch.zeros((count, 3)))


def table_entry(spec: SceneSpec) -> CatalogObject:
    """The table as a catalog-style entry (its frame is the box centre), so predicates can treat it like an object."""
    length, width = spec.table_size
    return CatalogObject(
        name="table",
        object_class="furniture",
        description="the work table",
        colors=(),
        rgba=spec.table_rgba,
        mass=1.0,
        static_friction=1.0,
        dynamic_friction=1.0,
        restitution=0.0,
        source={"kind": "scene"},
        license="n/a",
        parts=(Part("box", (length / 2, width / 2, TABLE_HEIGHT / 2), (0.0, 0.0, 0.0)),),
    )
