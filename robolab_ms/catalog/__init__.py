"""The object catalog: every object a scene may place, with its physical and descriptive metadata.

The catalog is data (assets/catalog.yaml). This module reads and checks it, and builds SAPIEN actors from entries.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robolab_ms.catalog.procedural import GENERATORS, Part, generate
from robolab_ms.content import Fields, content_dir, load_yaml
from robolab_ms.errors import SpecError, UnknownNameError

if TYPE_CHECKING:
    import sapien

    from mani_skill.envs.scene import ManiSkillScene
    from mani_skill.utils.structs import Actor

OBJECT_CLASSES = (
    "fruit", "vegetable", "food", "container", "tableware", "utensil", "tool", "toy", "block",
    "electronics", "bottle", "can", "box", "furniture", "other",
)  # fmt: skip


@dataclass(frozen=True)
class CatalogObject:
    """One catalog entry."""

    name: str
    object_class: str
    description: str
    colors: tuple[str, ...]
    rgba: tuple[float, float, float, float]
    mass: float
    static_friction: float
    dynamic_friction: float
    restitution: float
    source: dict[str, Any]
    license: str
    is_container: bool = False
    parts: tuple[Part, ...] = field(default=(), repr=False)

    @cached_property
    def points(self) -> np.ndarray:
        """Surface points of the collision geometry, object frame (N, 3)."""
        return np.concatenate([part.surface_points() for part in self.parts])

    @cached_property
    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds in the object frame, [[min x, y, z], [max x, y, z]]."""
        return np.stack([self.points.min(axis=0), self.points.max(axis=0)])

    @property
    def dimensions(self) -> np.ndarray:
        """Full extent along x, y, z (m)."""
        return self.bounds[1] - self.bounds[0]

    @cached_property
    def density(self) -> float:
        """Density that gives the catalog mass over the parts' total volume (kg/m^3)."""
        return self.mass / sum(part.volume() for part in self.parts)

    def build(self, scene: ManiSkillScene, name: str, initial_pose: sapien.Pose) -> Actor:
        """Build this object as a dynamic actor called `name`."""
        import sapien

        builder = scene.create_actor_builder()
        material = sapien.pysapien.physx.PhysxMaterial(self.static_friction, self.dynamic_friction, self.restitution)
        render_material = sapien.render.RenderMaterial(base_color=list(self.rgba), roughness=0.6)
        for part in self.parts:
            pose = sapien.Pose(p=list(part.position), q=list(part.rotation))
            common = dict(pose=pose, material=material, density=self.density)
            if part.shape == "box":
                builder.add_box_collision(half_size=list(part.size), **common)
                builder.add_box_visual(pose=pose, half_size=list(part.size), material=render_material)
            elif part.shape == "sphere":
                builder.add_sphere_collision(radius=part.size[0], **common)
                builder.add_sphere_visual(pose=pose, radius=part.size[0], material=render_material)
            elif part.shape == "capsule":
                builder.add_capsule_collision(radius=part.size[0], half_length=part.size[1], **common)
                builder.add_capsule_visual(
                    pose=pose, radius=part.size[0], half_length=part.size[1], material=render_material
                )
            else:
                builder.add_cylinder_collision(radius=part.size[0], half_length=part.size[1], **common)
                builder.add_cylinder_visual(
                    pose=pose, radius=part.size[0], half_length=part.size[1], material=render_material
                )
        builder.initial_pose = initial_pose
        return builder.build(name=name)


class Catalog:
    """All catalog objects by name."""

    def __init__(self, objects: dict[str, CatalogObject], file: Path) -> None:
        self.objects = objects
        self.file = file

    def __getitem__(self, name: str) -> CatalogObject:
        if name not in self.objects:
            raise UnknownNameError("catalog object", name, self.objects)
        return self.objects[name]

    def __contains__(self, name: str) -> bool:
        return name in self.objects

    def __len__(self) -> int:
        return len(self.objects)

    def names(self) -> list[str]:
        return sorted(self.objects)


COLOR_NAMES = {
    "yellow": (0.95, 0.8, 0.15), "white": (0.92, 0.92, 0.9), "red": (0.8, 0.1, 0.1), "green": (0.15, 0.6, 0.2),
    "blue": (0.15, 0.3, 0.8), "orange": (0.95, 0.5, 0.1), "grey": (0.5, 0.5, 0.5), "black": (0.08, 0.08, 0.08),
    "brown": (0.45, 0.3, 0.15), "purple": (0.5, 0.2, 0.6), "pink": (0.95, 0.55, 0.7), "silver": (0.75, 0.75, 0.78),
}  # fmt: skip


def _read_object(name: str, fields: Fields) -> CatalogObject:
    fields.only([
        "class", "description", "colors", "rgba", "mass", "friction", "restitution", "source", "license", "container",
    ])  # fmt: skip
    colors = fields.get("colors", list)
    for color in colors:
        if color not in COLOR_NAMES:
            raise fields.error("colors", f"'{color}' is not a known colour name", f"Use one of {', '.join(COLOR_NAMES)}")
    default_rgba = [*COLOR_NAMES[colors[0]], 1.0] if colors else None
    rgba = fields.number_list("rgba", 4, default_rgba)
    if rgba is None:
        raise fields.error("rgba", "is missing and there is no colour name to derive it from", "Add colors or rgba")
    friction = fields.sub("friction")
    friction.only(["static", "dynamic"])
    source = fields.sub("source")
    kind = source.choice("kind", ["procedural"])
    generator = source.choice("generator", GENERATORS)
    params = source.get("params", dict, {})
    try:
        parts = generate(generator, params)
    except TypeError as error:
        raise source.error("params", f"do not fit generator '{generator}' ({error})") from None
    mass = fields.get("mass", float)
    if mass <= 0:
        raise fields.error("mass", f"must be positive, got {mass}")
    return CatalogObject(
        name=name,
        object_class=fields.choice("class", OBJECT_CLASSES),
        description=fields.get("description", str),
        colors=tuple(colors),
        rgba=tuple(rgba),
        mass=mass,
        static_friction=friction.get("static", float),
        dynamic_friction=friction.get("dynamic", float),
        restitution=fields.get("restitution", float, 0.0),
        source={"kind": kind, "generator": generator, "params": params},
        license=fields.get("license", str),
        is_container=fields.get("container", bool, False),
        parts=tuple(parts),
    )


def read_catalog(file: Path) -> Catalog:
    """Read and check a catalog file."""
    data = Fields(load_yaml(file), file)
    data.only(["version", "objects"])
    entries = data.sub("objects")
    objects = {}
    for name in entries.data:
        if not isinstance(name, str) or not name.replace("_", "").isalnum():
            raise SpecError(file, f"objects.{name}", "object names must be letters, digits and underscores")
        objects[name] = _read_object(name, entries.sub(name))
    return Catalog(objects, file)


@lru_cache(maxsize=None)
def load_catalog(file: Path | None = None) -> Catalog:
    """The shipped catalog (assets/catalog.yaml), or another catalog file."""
    return read_catalog(file or content_dir("assets") / "catalog.yaml")
