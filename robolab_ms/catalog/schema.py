"""The catalog's schema: its entries (`CatalogObject`, which also builds itself as a SAPIEN actor), the whole
(`Catalog`), and the reader that checks a catalog file field by field (`read_catalog`) and joins the shipped catalog
with the users' (`load_catalog`)."""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robolab_ms.catalog.appearance import (
    box_mesh,
    cylinder_mesh,
    part_look,
    projected_mesh,
    render_material,
    scene_renders,
    sidecar_texture_material,
    visual_mesh_builder,
)
from robolab_ms.catalog.meshes import hull_volume, package_file, read_hulls
from robolab_ms.catalog.modelled import GENERATORS as MODELLED_GENERATORS
from robolab_ms.catalog.modelled import PARAM_LIMITS as MODELLED_PARAM_LIMITS
from robolab_ms.catalog.modelled import Model
from robolab_ms.catalog.modelled import generate as generate_model
from robolab_ms.catalog.procedural import (
    GENERATORS,
    PARAM_CHOICES,
    Part,
    Quat,
    axis_angle_quat,
    generate,
    procedural_interior,
    quat_multiply,
    quat_to_matrix,
)
from robolab_ms.content import (
    USER_CATALOG,
    Fields,
    check_kind,
    check_range,
    content_dir,
    load_yaml,
    user_content_roots,
)
from robolab_ms.errors import RoboLabError, SpecError, UnknownNameError, did_you_mean

if TYPE_CHECKING:
    import sapien
    from mani_skill.envs.scene import ManiSkillScene
    from mani_skill.utils.structs import Actor

OBJECT_CLASSES = (
    "fruit", "vegetable", "food", "container", "tableware", "utensil", "tool", "toy", "block",
    "electronics", "bottle", "can", "box", "furniture", "other",
)  # fmt: skip
SHAPE_KINDS = {
    "scanned": "a 3D scan of a real object (HOPE, Google Scanned Objects, a scanned figure)",
    "modelled": "a mesh modelled after the real object: by hand, in CAD, or by a generator from a revolved or swept "
    "profile",
    "primitive": "boxes, cylinders, spheres, capsules or a torus standing in for the object",
}
REAL_SHAPES = ("scanned", "modelled")  # the shape kinds that show the real object's form


@dataclass(frozen=True)
class MeshTransform:
    """What makes a packaged mesh metric, upright and based: v_object = R(rotation_deg) (scale * v) + translation.

    `rotation_deg` is extrinsic x, then y, then z (degrees); `translation` puts the centre of the bottom at the
    origin (written by `robolab catalog build`).
    """

    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def quaternion(self) -> Quat:
        """The rotation as (w, x, y, z)."""
        rx, ry, rz = (math.radians(angle) for angle in self.rotation_deg)
        q = axis_angle_quat((1, 0, 0), rx)
        q = quat_multiply(axis_angle_quat((0, 1, 0), ry), q)
        return quat_multiply(axis_angle_quat((0, 0, 1), rz), q)

    def apply(self, vertices: np.ndarray, translate: bool = True) -> np.ndarray:
        """Source-frame vertices (N, 3) into the object frame."""
        moved = (np.asarray(vertices) * np.asarray(self.scale)) @ quat_to_matrix(self.quaternion).T
        return moved + np.asarray(self.translation) if translate else moved


@dataclass(frozen=True)
class CatalogObject:
    """One catalog entry. Procedural objects carry primitive `parts`; mesh objects a visual mesh from an installed
    package (source kind `mesh`) or a file beside their catalog file (source kind `file`, what `robolab catalog add`
    writes), a `transform` and a hull file of convex collision pieces (`collision_file`); modelled objects (source
    kind `modelled`) surfaces made by a generator of robolab_ms.catalog.modelled (`model`) and a hull file."""

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
    is_fixture: bool = False  # built kinematic where the scene puts it: no jitter, no push moves it (shelves)
    parts: tuple[Part, ...] = field(default=(), repr=False)
    interior: tuple[float, float, float] | None = None
    recorded_dimensions: tuple[float, float, float] | None = None
    transform: MeshTransform | None = None
    collision_method: str = "primitives"
    collision_file: Path | None = None
    palette: tuple[tuple[float, float, float, float], ...] = ()
    folder: Path | None = None  # the catalog file's folder: where the paths of a `file` source start
    shape: str = "primitive"  # how its form was made: one of SHAPE_KINDS

    @property
    def is_procedural(self) -> bool:
        return self.source.get("kind") == "procedural"

    @property
    def is_modelled(self) -> bool:
        return self.source.get("kind") == "modelled"

    @property
    def model(self) -> Model | None:
        """The surfaces and convex pieces of a modelled object (None for other objects); made once per process."""
        if not self.is_modelled:
            return None
        return generate_model(self.source["generator"], self.source["params"])

    @property
    def has_real_shape(self) -> bool:
        """Whether the object shows the real object's form (a scan or a model), not a stand-in of primitives."""
        return self.shape in REAL_SHAPES

    @cached_property
    def hulls(self) -> tuple[np.ndarray, ...]:
        """Convex collision pieces of a mesh object, object frame (empty for procedural objects)."""
        if self.collision_file is None:
            return ()
        if not self.collision_file.is_file():
            raise RoboLabError(
                f"catalog object '{self.name}': its collision file {self.collision_file.name} is missing. "
                "Run 'robolab catalog build' to make it"
            )
        return read_hulls(str(self.collision_file))

    @cached_property
    def points(self) -> np.ndarray:
        """Surface points of the collision geometry, object frame (N, 3)."""
        if self.parts:
            return np.concatenate([part.surface_points() for part in self.parts])
        return np.concatenate(self.hulls)

    @cached_property
    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds in the object frame, [[min x, y, z], [max x, y, z]]."""
        return np.stack([self.points.min(axis=0), self.points.max(axis=0)])

    @property
    def dimensions(self) -> np.ndarray:
        """Full extent along x, y, z (m) of the collision geometry (from its sample points)."""
        return self.bounds[1] - self.bounds[0]

    @cached_property
    def exact_bounds(self) -> np.ndarray:
        """Exact axis-aligned bounds of the collision geometry, [[min x, y, z], [max x, y, z]]."""
        if not self.parts:
            return self.bounds
        lows = [np.asarray(part.position) - part.half_extent() for part in self.parts]
        highs = [np.asarray(part.position) + part.half_extent() for part in self.parts]
        return np.stack([np.min(lows, axis=0), np.max(highs, axis=0)])

    @cached_property
    def levels(self) -> tuple[float, ...]:
        """Heights (object frame, lowest first) of the tops of the object's boards: its collision pieces that
        reach over at least half the object's extent along x and along y (a shelf's levels, a bin's floor)."""
        if self.parts:
            boxes = [
                (np.asarray(p.position) - p.half_extent(), np.asarray(p.position) + p.half_extent()) for p in self.parts
            ]
        else:
            boxes = [(hull.min(axis=0), hull.max(axis=0)) for hull in self.hulls]
        extent = self.exact_bounds[1] - self.exact_bounds[0]
        tops = {round(float(high[2]), 5) for low, high in boxes if ((high - low)[:2] >= extent[:2] / 2).all()}
        return tuple(sorted(tops))

    @cached_property
    def volume(self) -> float:
        """Volume of the collision geometry (m^3)."""
        if self.parts:
            return sum(part.volume() for part in self.parts)
        return sum(hull_volume(hull) for hull in self.hulls)

    @cached_property
    def density(self) -> float:
        """Density that gives the catalog mass over the collision geometry's volume (kg/m^3)."""
        return self.mass / self.volume

    def visual_files(self) -> list[Path]:
        """The visual mesh files of a mesh object: packaged, or beside its catalog file (none for procedural and
        modelled objects)."""
        if self.is_procedural or self.is_modelled:
            return []
        if self.source["kind"] == "file":
            return [self.folder / path for path in self.source["paths"]]
        return [package_file(self.source["package"], path) for path in self.source["paths"]]

    def build(self, scene: ManiSkillScene | sapien.Scene, name: str, initial_pose: sapien.Pose) -> Actor:
        """Build this object as an actor called `name` (in a ManiSkill scene, or a plain SAPIEN scene): dynamic, or
        kinematic for a fixture (it stays where it is put; nothing the robot or other objects do moves it). In a
        scene that cannot render it gets its collision shapes only."""
        import sapien

        builder = visual_mesh_builder(scene)
        material = sapien.pysapien.physx.PhysxMaterial(self.static_friction, self.dynamic_friction, self.restitution)
        looks = scene_renders(scene)
        if self.parts:
            self._add_parts(builder, material, looks)
        elif self.is_modelled:
            self._add_model(builder, material, looks)
        else:
            self._add_mesh(builder, material, looks)
        builder.initial_pose = initial_pose
        return builder.build_kinematic(name=name) if self.is_fixture else builder.build(name=name)

    def _render_materials(self) -> list:
        """One material per colour of the object (tint 0, 1, ...), each with an image texture made from that
        colour and the kind of surface the part is (see robolab_ms.catalog.appearance)."""
        colours = self.palette or (self.rgba,)
        return [render_material(part_look(self, tint)) for tint in range(len(colours))]

    def _add_parts(self, builder, material, looks: bool) -> None:
        import sapien

        render_materials = self._render_materials() if looks else []
        for part in self.parts:
            pose = sapien.Pose(p=list(part.position), q=list(part.rotation))
            common = dict(pose=pose, material=material, density=self.density)
            if part.shape == "box":
                builder.add_box_collision(half_size=list(part.size), **common)
            elif part.shape == "sphere":
                builder.add_sphere_collision(radius=part.size[0], **common)
            elif part.shape == "capsule":
                builder.add_capsule_collision(radius=part.size[0], half_length=part.size[1], **common)
            else:
                builder.add_cylinder_collision(radius=part.size[0], half_length=part.size[1], **common)
            if looks:
                self._add_part_visual(builder, part, pose, render_materials[min(part.tint, len(render_materials) - 1)])

    @staticmethod
    def _add_part_visual(builder, part: Part, pose: sapien.Pose, render_material: sapien.render.RenderMaterial) -> None:
        if part.shape == "box":
            builder.add_visual_mesh(box_mesh(tuple(part.size)), render_material, pose)  # a whole label per face
        elif part.shape == "sphere":
            builder.add_sphere_visual(pose=pose, radius=part.size[0], material=render_material)
        elif part.shape == "capsule":
            builder.add_capsule_visual(
                pose=pose, radius=part.size[0], half_length=part.size[1], material=render_material
            )
        else:  # SAPIEN's cylinder visual has no texture coordinates: a generated mesh carries the texture
            builder.add_visual_mesh(cylinder_mesh(part.size[0], part.size[1]), render_material, pose)

    def _add_model(self, builder, material, looks: bool) -> None:
        """A modelled object: each generated surface with the look of its colour, and the hull file's pieces."""
        for surface in self.model.surfaces if looks else ():
            look = part_look(self, surface.tint, surface.kind, surface.rgb, surface.shade)
            builder.add_visual_mesh(surface.mesh, render_material(look))
        builder.add_multiple_convex_collisions_from_file(
            str(self.collision_file), material=material, density=self.density
        )

    def _add_mesh(self, builder, material, looks: bool) -> None:
        import sapien

        transform = self.transform or MeshTransform()
        pose = sapien.Pose(p=list(transform.translation), q=list(transform.quaternion))
        for path in self.visual_files() if looks else []:
            if self.source.get("textured"):
                builder.add_visual_from_file(
                    str(path), pose=pose, scale=list(transform.scale), material=sidecar_texture_material(path)
                )
            else:  # no texture of its own: texture coordinates projected from the shape, a texture of its kind
                mesh = projected_mesh(str(path), tuple(transform.scale))
                builder.add_visual_mesh(mesh, self._render_materials()[0], pose)
        builder.add_multiple_convex_collisions_from_file(
            str(self.collision_file), material=material, density=self.density
        )


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
    "tan": (0.82, 0.68, 0.47), "cream": (0.96, 0.92, 0.8), "dark_green": (0.1, 0.35, 0.12),
    "light_green": (0.55, 0.8, 0.3), "light_blue": (0.55, 0.75, 0.95), "dark_red": (0.45, 0.05, 0.08),
    "beige": (0.9, 0.85, 0.7), "gold": (0.85, 0.65, 0.15), "navy": (0.08, 0.12, 0.35),
}  # fmt: skip

COLLISION_METHODS = {
    "primitives": "the procedural object's own boxes, spheres, capsules and cylinders (exact)",
    "packaged_pieces": "convex pieces shipped with the mesh by its package",
    "convex_hull": "the convex hull of the visual mesh (for nearly convex objects)",
    "coacd": "convex decomposition of the visual mesh by coacd, run once by 'robolab catalog build'",
    "modelled_pieces": "the convex pieces a modelled generator builds with its shape (wall sectors, tube segments)",
}
MODELLED_COLLISION_METHODS = ["modelled_pieces", "coacd"]
MESH_SOURCE_FIELDS = ["kind", "package", "paths", "textured", "collision_pieces"]
FILE_SOURCE_FIELDS = ["kind", "paths", "textured", "origin"]  # a mesh file beside the catalog file


def collision_dir(catalog_file: Path) -> Path:
    """Where the hull files of a catalog's mesh objects live (beside the catalog file)."""
    return catalog_file.parent / "collision"


MAX_OBJECT_SIZE = 2.0  # m, any extent of a table-top object
MAX_MASS = 100.0  # kg
MAX_FRICTION = 5.0
CATALOG_VERSION = 1


def _read_object(name: str, fields: Fields) -> CatalogObject:
    fields.only(
        [
            "class",
            "description",
            "colors",
            "rgba",
            "mass",
            "friction",
            "restitution",
            "source",
            "license",
            "container",
            "interior",
            "dimensions",
            "transform",
            "collision",
            "fixture",
            "shape",
        ]
    )
    colors = fields.get("colors", list)
    for index, color in enumerate(colors):
        check_kind(color, str, lambda problem, fix, index=index: fields.error(f"colors[{index}]", problem, fix))
        if color not in COLOR_NAMES:
            raise fields.error(
                f"colors[{index}]", f"'{color}' is not a known colour name", did_you_mean(color, COLOR_NAMES)
            )
    default_rgba = [*COLOR_NAMES[colors[0]], 1.0] if colors else None
    rgba = fields.number_list("rgba", 4, default_rgba, low=0.0, high=1.0)
    if rgba is None:
        raise fields.error("colors", "is empty and rgba is not given", "Name at least one colour, or give rgba")
    palette = (tuple(rgba), *((*COLOR_NAMES[color], 1.0) for color in colors[1:]))
    friction = fields.sub("friction")
    friction.only(["static", "dynamic"])
    static_friction = friction.positive("static", MAX_FRICTION)
    dynamic_friction = friction.positive("dynamic", MAX_FRICTION)
    if dynamic_friction > static_friction:
        raise friction.error("dynamic", f"must be between 0 and static ({static_friction}), got {dynamic_friction}")
    mass = fields.positive("mass", MAX_MASS, unit="kg")
    is_container = fields.get("container", bool, False)
    is_fixture = fields.get("fixture", bool, False)
    interior = fields.number_list("interior", 3, None, low=0.0, high=MAX_OBJECT_SIZE, above=True, unit="m")
    if interior is not None and not is_container:
        raise fields.error(
            "interior", "is given for an object that is not a container", "Set container: true, or leave interior out"
        )
    dimensions = fields.number_list("dimensions", 3, None, low=0.0, high=MAX_OBJECT_SIZE, above=True, unit="m")
    collision = fields.sub("collision", {})
    collision.only(["method", "file"])
    source = fields.sub("source")
    kind = source.choice("kind", ["procedural", "modelled", "mesh", "file"])
    shape = _read_shape(fields, kind)
    parts: list[Part] = []
    transform = None
    collision_file = None
    if kind == "procedural":
        source.only(["kind", "generator", "params"])
        generator = source.choice("generator", GENERATORS)
        params = _read_generator_params(source.sub("params", {}), generator, GENERATORS[generator])
        try:
            parts = generate(generator, params)
        except (TypeError, ValueError, ArithmeticError) as error:
            raise source.error("params", f"do not fit generator '{generator}' ({error})") from None
        _check_parts(source, parts)
        if is_container and interior is None:
            interior = procedural_interior(generator, params)
        method = collision.choice("method", ["primitives"], "primitives")
        source_record = {"kind": kind, "generator": generator, "params": params}
    elif kind == "modelled":
        source_record, interior = _read_modelled(name, fields, source, is_container, interior)
        method = collision.choice("method", MODELLED_COLLISION_METHODS)
        collision_file = collision_dir(fields.file) / collision.get("file", str, f"{name}.obj")
        transform = MeshTransform()
        if dimensions is None:
            raise fields.error(
                "dimensions", "is missing for a modelled object", "Run 'robolab catalog build' to fill it in"
            )
    else:
        source.only(MESH_SOURCE_FIELDS if kind == "mesh" else FILE_SOURCE_FIELDS)
        paths = source.get("paths", list)
        if not paths:
            raise source.error(
                "paths",
                "is empty",
                "List the mesh files inside the package"
                if kind == "mesh"
                else "List the mesh files, relative to the catalog file's folder",
            )
        for index, path in enumerate(paths):
            check_kind(path, str, lambda problem, fix, index=index: source.error(f"paths[{index}]", problem, fix))
            if path in paths[:index]:
                raise source.error(f"paths[{index}]", f"'{path}' is listed twice", "List each mesh file once")
            if kind == "file" and not (Path(fields.file).parent / path).is_file():
                raise source.error(
                    f"paths[{index}]",
                    f"'{path}' is not a file beside the catalog file",
                    f"Put the mesh at {Path(fields.file).parent / path}, or correct the path",
                )
        if kind == "file":
            source_record = {
                "kind": kind,
                "paths": paths,
                "textured": source.get("textured", bool, False),
                "origin": source.get("origin", str, ""),
            }
        else:
            source_record = {
                "kind": kind,
                "package": source.get("package", str),
                "paths": paths,
                "textured": source.get("textured", bool, False),
                "collision_pieces": source.get("collision_pieces", str, ""),
            }
        methods = [
            m
            for m in COLLISION_METHODS
            if m not in ("primitives", "modelled_pieces") and (kind == "mesh" or m != "packaged_pieces")
        ]
        method = collision.choice("method", methods)
        if method == "packaged_pieces" and not source_record["collision_pieces"]:
            raise source.error(
                "collision_pieces",
                "is needed for collision method 'packaged_pieces'",
                "Give a glob of the packaged convex pieces, relative to the first path's folder",
            )
        collision_file = collision_dir(fields.file) / collision.get("file", str, f"{name}.obj")
        spec = fields.sub("transform", {})
        spec.only(["scale", "rotation_deg", "translation"])
        if isinstance(spec.data.get("scale"), list):
            scale_xyz = spec.number_list("scale", 3, low=0.0, high=1000.0, above=True)
        else:
            scale_xyz = [spec.positive("scale", 1000.0, 1.0)] * 3
        transform = MeshTransform(
            scale=tuple(scale_xyz),
            rotation_deg=tuple(spec.number_list("rotation_deg", 3, [0.0, 0.0, 0.0], low=-360.0, high=360.0)),
            translation=tuple(spec.number_list("translation", 3, [0.0, 0.0, 0.0], low=-1.0, high=1.0, unit="m")),
        )
        if dimensions is None:
            raise fields.error(
                "dimensions", "is missing for a mesh object", "Run 'robolab catalog build' to fill it in"
            )
    if is_container and interior is None:
        raise fields.error("interior", "is missing for a container", "Give the inner size [x, y, z] in metres")
    if interior is not None and dimensions is not None and any(i > d for i, d in zip(interior, dimensions)):
        raise fields.error(
            "interior",
            f"{interior} is larger than the object's dimensions {dimensions}",
            "Give the inner size, which fits within the outer one",
        )
    return CatalogObject(
        name=name,
        object_class=fields.choice("class", OBJECT_CLASSES),
        description=fields.get("description", str),
        colors=tuple(colors),
        rgba=tuple(rgba),
        mass=mass,
        static_friction=static_friction,
        dynamic_friction=dynamic_friction,
        restitution=fields.number("restitution", 0.0, 1.0, 0.0),
        source=source_record,
        license=fields.get("license", str),
        is_container=is_container,
        is_fixture=is_fixture,
        parts=tuple(parts),
        interior=tuple(interior) if interior else None,
        recorded_dimensions=tuple(dimensions) if dimensions else None,
        transform=transform,
        collision_method=method,
        collision_file=collision_file,
        palette=palette,
        folder=Path(fields.file).parent if kind == "file" else None,
        shape=shape,
    )


def _read_modelled(
    name: str, fields: Fields, source: Fields, is_container: bool, interior: list[float] | None
) -> tuple[dict[str, Any], list[float] | None]:
    """The source of a modelled object (its generator and checked parameters) and its interior (the generator's,
    for a container that gives none)."""
    source.only(["kind", "generator", "params"])
    if fields.has("transform"):
        raise fields.error(
            "transform",
            "is given for a modelled object",
            "Leave it out: a generator makes its shape in the object frame",
        )
    generator = source.choice("generator", MODELLED_GENERATORS)
    params = _read_generator_params(
        source.sub("params", {}), generator, MODELLED_GENERATORS[generator], MODELLED_PARAM_LIMITS
    )
    try:
        model = generate_model(generator, params)
    except (TypeError, ValueError, ArithmeticError, IndexError) as error:
        raise source.error(
            "params", f"do not fit modelled generator '{generator}' ({error})", "Check the values"
        ) from None
    extent = model.bounds[1] - model.bounds[0]
    if not np.isfinite(extent).all() or extent.min() <= 0 or extent.max() > MAX_OBJECT_SIZE:
        raise source.error(
            "params", f"make an object of size {np.round(extent, 3).tolist()} m", f"Keep it within {MAX_OBJECT_SIZE} m"
        )
    if is_container and interior is None:
        if model.interior is None:
            raise fields.error(
                "interior", f"is missing, and generator '{generator}' makes no vessel", "Give the inner size [x, y, z]"
            )
        interior = [round(float(d), 4) for d in model.interior]
    return {"kind": "modelled", "generator": generator, "params": params}, interior


def modelled_model(name: str, entry: dict, file: Path) -> Model:
    """The model of a modelled entry of catalog `file` as written there (before `robolab catalog build` completes
    it), its source checked as `read_catalog` checks it."""
    fields = Fields(entry, file, f"objects.{name}")
    source_record, _ = _read_modelled(name, fields, fields.sub("source"), False, None)
    return generate_model(source_record["generator"], source_record["params"])


DEFAULT_SHAPE = {
    "procedural": "primitive",
    "modelled": "modelled",
    "file": "modelled",
}  # a packaged mesh (`mesh`) must state its kind


def _read_shape(fields: Fields, kind: str) -> str:
    """The entry's shape kind: given, or the default of its source kind; a procedural object is never a scan."""
    if not fields.has("shape") and kind not in DEFAULT_SHAPE:
        raise fields.error(
            "shape",
            f"is missing for a packaged mesh (source kind '{kind}')",
            f"Say how its form was made: {', '.join(SHAPE_KINDS)}",
        )
    shape = fields.choice("shape", SHAPE_KINDS, DEFAULT_SHAPE.get(kind))
    if kind == "procedural" and shape == "scanned":
        raise fields.error(
            "shape",
            "is 'scanned' for a procedural object, which a generator makes",
            "Write modelled (a generated profile of the real object) or primitive",
        )
    if kind == "modelled" and shape != "modelled":
        raise fields.error(
            "shape", f"is '{shape}' for a modelled object (source kind modelled)", "Write modelled, or leave it out"
        )
    return shape


GENERATOR_PARAM_LIMITS = {"bend_deg": (0.0, 360.0), "segments": (3, 64), "levels": (1, 20)}
POINT_LISTS = {"profile": 3}  # parameters that are lists of [r, z] points, and the fewest points each takes


def _read_generator_params(
    params: Fields, generator: str, function: Callable[..., Any], limits: dict[str, tuple[float, float]] | None = None
) -> dict[str, Any]:
    """A generator's parameters (procedural or modelled), checked against its signature: names, types and ranges
    (lengths in m up to MAX_OBJECT_SIZE; a length whose default is 0 may be 0, meaning none; `limits` other ranges
    by name)."""
    limits = {**GENERATOR_PARAM_LIMITS, **(limits or {})}
    signature = inspect.signature(function).parameters
    for key in params.data:
        if key not in signature:
            raise params.error(
                str(key), f"is not a parameter of generator '{generator}'", did_you_mean(str(key), signature)
            )
    values: dict[str, Any] = {}
    for key, parameter in signature.items():
        default = parameter.default
        if not params.has(key):
            if default is inspect.Parameter.empty:
                raise params.error(key, f"is missing (generator '{generator}' needs it)", "Add it")
            continue
        annotation = str(parameter.annotation)
        if annotation == "bool":
            values[key] = params.get(key, bool)
        elif annotation == "str":
            choices = PARAM_CHOICES.get(key)
            values[key] = params.choice(key, choices) if choices else params.get(key, str)
        elif annotation == "int":
            low, high = limits[key]
            value = params.get(key, int)
            check_range(value, low, high, False, "", lambda problem, fix, key=key: params.error(key, problem, fix))
            values[key] = value
        elif annotation == "list[float]":
            values[key] = params.number_list(key, 3, low=0.0, high=MAX_OBJECT_SIZE, above=True, unit="m")
        elif annotation == "list[list[float]]":
            values[key] = _read_points(params, key, POINT_LISTS.get(key, 1))
        else:
            low, high = limits.get(key, (0.0, MAX_OBJECT_SIZE))
            values[key] = params.number(key, low, high, above=default != 0.0)
    return values


def _read_points(params: Fields, key: str, fewest: int) -> list[list[float]]:
    """A list of at least `fewest` [r, z] points (m, each from 0 to MAX_OBJECT_SIZE); errors name the entry."""
    points = params.get(key, list)
    if len(points) < fewest:
        raise params.error(key, f"must list at least {fewest} [r, z] points, got {len(points)}", "Add points")
    checked = []
    for index, point in enumerate(points):
        entry = Fields({f"{key}[{index}]": point}, params.file, params.path)
        checked.append(entry.number_list(f"{key}[{index}]", 2, low=0.0, high=MAX_OBJECT_SIZE, unit="m"))
    return checked


def _check_parts(source: Fields, parts: list[Part]) -> None:
    """The generated primitives have positive, finite sizes and the object fits on a table."""
    if not parts:
        raise source.error("params", "make no parts", "Check the parameters")
    for part in parts:
        numbers = np.array([*part.size, *part.position, *part.rotation], dtype=float)
        if not np.isfinite(numbers).all() or min(part.size) <= 0:
            raise source.error(
                "params",
                f"make a {part.shape} part of size {part.size}, which is not positive",
                "Check that the parameters fit together (for example a length longer than the head)",
            )
    extent = np.max([np.asarray(p.position) + p.half_extent() for p in parts], 0) - np.min(
        [np.asarray(p.position) - p.half_extent() for p in parts], 0
    )
    if extent.max() > MAX_OBJECT_SIZE:
        raise source.error(
            "params", f"make an object {extent.max():.2f} m across", f"Keep objects within {MAX_OBJECT_SIZE} m"
        )


def read_catalog(file: Path) -> Catalog:
    """Read and check a catalog file."""
    data = Fields(load_yaml(file), file)
    data.only(["version", "objects"])
    version = data.get("version", int, CATALOG_VERSION)
    if version != CATALOG_VERSION:
        raise data.error(
            "version", f"{version} is not a catalog version this robolab_ms reads", f"Write version: {CATALOG_VERSION}"
        )
    entries = data.sub("objects")
    if not entries.data:
        raise data.error("objects", "is empty", "Add at least one object")
    objects = {}
    for name in entries.data:
        if not isinstance(name, str) or not name.replace("_", "").isalnum() or not name.isascii():
            raise SpecError(
                file,
                f"objects.{name}",
                "object names must be letters, digits and underscores",
                "Rename it, e.g. red_mug",
            )
        objects[name] = _read_object(name, entries.sub(name))
    return Catalog(objects, file)


def shipped_catalog_file() -> Path:
    """The catalog file shipped with robolab_ms (assets/catalog.yaml), which `robolab catalog build` rewrites."""
    return content_dir("assets") / "catalog.yaml"


def user_catalog_files() -> list[Path]:
    """The catalog files of the user content folders (ROBOLAB_CONTENT, --content): each folder's assets/catalog.yaml,
    where `robolab catalog add` writes."""
    files = [root / USER_CATALOG for root in user_content_roots()]
    return [file for file in files if file.is_file()]


def load_catalog(file: Path | None = None) -> Catalog:
    """One catalog file; without one, the shipped catalog (assets/catalog.yaml) joined by the objects of every user
    catalog (`user_catalog_files`). Read once per process and file version (a file changed on disk is read again)."""
    if file is not None:
        return _read_catalog_version(Path(file), _file_version(Path(file)))
    files = [shipped_catalog_file(), *user_catalog_files()]
    return _joined_catalogs(tuple((file, _file_version(file)) for file in files))


def _file_version(file: Path) -> tuple[int, int]:
    try:
        status = file.stat()
    except OSError:
        return (0, 0)  # read_catalog reports the missing file
    return (status.st_mtime_ns, status.st_size)


@lru_cache(maxsize=None)
def _read_catalog_version(file: Path, version: tuple[int, int]) -> Catalog:
    return read_catalog(file)


@lru_cache(maxsize=None)
def _joined_catalogs(files: tuple[tuple[Path, tuple[int, int]], ...]) -> Catalog:
    """The catalogs of `files` as one (the first file's is the catalog's file); a name in two files is an error."""
    catalogs = [_read_catalog_version(file, version) for file, version in files]
    if len(catalogs) == 1:
        return catalogs[0]
    objects: dict[str, CatalogObject] = {}
    found_in: dict[str, Path] = {}
    for catalog in catalogs:
        for name, entry in catalog.objects.items():
            if name in objects:
                raise RoboLabError(
                    f"catalog object '{name}' is defined twice: in {found_in[name]} and in {catalog.file}. Names "
                    "must be unique across the shipped catalog and the user catalogs (assets/catalog.yaml of each "
                    "folder of ROBOLAB_CONTENT / --content); rename one of them"
                )
            objects[name], found_in[name] = entry, catalog.file
    return Catalog(objects, catalogs[0].file)


def narrowest_width(entry: CatalogObject) -> float:
    """An object's narrowest horizontal width as the catalog stands it (m): the opening a gripper closing across the
    whole object from above needs. A thin part (a handle, a rim, a wall) may be narrower."""
    from scipy.spatial import ConvexHull

    xy = entry.points[:, :2]
    outline = xy[ConvexHull(xy).vertices]
    edges = np.roll(outline, -1, axis=0) - outline
    normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1) / np.linalg.norm(edges, axis=1, keepdims=True)
    projected = outline @ normals.T  # the narrowest width is measured across one of the outline's edges
    return float((projected.max(axis=0) - projected.min(axis=0)).min())
