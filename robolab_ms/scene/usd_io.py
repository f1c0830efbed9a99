"""Scenes as USD: a scene file written as a USD stage (UsdGeom geometry, UsdPhysics bodies) and a USD layout read
back into a scene file.

Export (`export_scene`) writes FILE.usda and, beside it, an `assets/` folder with one USD file per catalog object
(`assets/<catalog name>.usda` for procedural objects, `.usdc` for mesh objects, textures under `assets/textures/`).
The scene references the assets by relative paths, so the folder may be moved as a whole. Stage: Z up, metres,
kilograms; the scene's frame (robot base at the origin, x away from the robot, y to its left, the table top at
z = 0).

    /PhysicsScene                  UsdPhysics.Scene, gravity 9.81 m/s^2 down
    /World                         Xform, the default prim; robolab:scene, robolab:description, robolab:jitter*
      table, robot_pedestal        Cubes with CollisionAPI and no RigidBodyAPI: static colliders
      <body>                       Xform per scene object, named after it (a valid USD identifier; the scene's
                                   name in robolab:name), referencing its catalog asset; xformOp:translate (double3)
                                   and xformOp:orient (quatd); RigidBodyAPI and MassAPI (the catalog mass); a fixture
                                   (shelf) is a kinematic body; robolab:catalog, robolab:restsOn, robolab:level

An asset is an Xform (kind component) holding its geometry in its own frame (the catalog object's: z up, origin at
the centre of the bottom): a procedural object's primitives as UsdGeom Cube / Sphere / Capsule / Cylinder, each a
collider as well; a mesh object's visual meshes as UsdGeom.Mesh (the catalog transform applied, texture or colour
as UsdPreviewSurface) and its convex collision pieces as guide-purpose meshes with MeshCollisionAPI
approximation convexHull; a UsdPhysics material with the catalog's friction and restitution.

Import (`import_scene`) reads the bodies of a USD layout (this exporter's or one made elsewhere), maps each to a
catalog object (robolab:catalog, a `--map` file, or the name of its referenced asset file), turns each world pose
into the scene file's x, y, yaw and tilt, keeps `rests_on` / `level` (robolab attributes, else inferred from the
heights), writes the scene file and reads it back through the scene loader.
"""

from __future__ import annotations

import fnmatch
import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.catalog import COLOR_NAMES, Catalog, CatalogObject, load_catalog
from robolab_ms.catalog.appearance import part_look
from robolab_ms.catalog.meshes import load_mesh
from robolab_ms.catalog.procedural import Part, quat_to_matrix
from robolab_ms.content import Fields, load_yaml
from robolab_ms.errors import RoboLabError, did_you_mean, make_folder
from robolab_ms.scene import (
    DEFAULT_TABLE_SIZE,
    RESERVED_NAMES,
    SETTLE_CLEARANCE,
    TABLE_CENTER_XY,
    TABLE_HEIGHT,
    SceneSpec,
    quat_multiply,
    read_scene,
    yaw_quat,
)

ASSETS_FOLDER = "assets"  # beside the exported scene file: one USD file per catalog object
TEXTURES_FOLDER = "textures"  # inside the assets folder
USD_SUFFIXES = (".usda", ".usd", ".usdc")
WORLD = "/World"
PHYSICS_SCENE = "/PhysicsScene"
GRAVITY = 9.81  # m/s^2
PEDESTAL_HALF = (0.15, 0.15, TABLE_HEIGHT / 2)  # the robot's stand, as the scene builder makes it
PEDESTAL_CENTER = (-0.08, 0.0, -TABLE_HEIGHT / 2 - 0.001)
ATTR = {  # custom attributes of the robolab: namespace
    "name": "robolab:name", "catalog": "robolab:catalog", "rests_on": "robolab:restsOn", "level": "robolab:level",
    "role": "robolab:role", "scene": "robolab:scene", "description": "robolab:description",
    "jitter_xy": "robolab:jitterXy", "jitter_yaw": "robolab:jitterYawDeg", "background": "robolab:background",
    "table_rgba": "robolab:tableRgba", "table_material": "robolab:tableMaterial", "class": "robolab:class",
    "license": "robolab:license",
}  # fmt: skip
ANGLE_DECIMALS = 9  # degrees in the imported scene file (1e-9 degrees is far below the round trip's 1e-6)
LENGTH_DECIMALS = 9  # metres in the imported scene file
STRAIGHT = 1e-9  # a rotation-matrix entry this close to 0 is 0 (a rotation about one axis only)
SUPPORT_NOTE_GAP = 0.01  # m: an imported body further than this from where it would rest gets a note


# ---------------------------------------------------------------------------------------------------- export
@dataclass
class ExportReport:
    """What `export_scene` wrote: the scene file, the asset files and the bodies."""

    usd: Path
    assets: list[Path]
    bodies: int
    problems: list[str] = field(default_factory=list)  # validation findings (empty for a good stage)

    def line(self) -> str:
        return (f"{self.usd}: {self.bodies} bodies, {len(self.assets)} asset file(s) in "
                f"{self.usd.parent / ASSETS_FOLDER}")  # fmt: skip


def _pxr():
    """The USD modules (usd-core), with a clear error when they are missing."""
    try:
        from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdPhysics, UsdShade, UsdValidation, Vt  # noqa: F401
    except ImportError as error:  # pragma: no cover - usd-core is pinned in requirements.lock
        raise RoboLabError(f"USD support needs the usd-core package ({error}). Install the pinned set-up with "
                           "'make setup'") from None  # fmt: skip
    import pxr

    return pxr


def export_scene(spec: SceneSpec, out: Path, catalog: Catalog | None = None) -> ExportReport:
    """Write scene `spec` as the USD stage `out` (.usda, .usd or .usdc) with its assets folder beside it; the
    written stage is opened and validated (RoboLabError listing what is wrong)."""
    pxr = _pxr()
    Sdf, Usd, UsdGeom, UsdPhysics = pxr.Sdf, pxr.Usd, pxr.UsdGeom, pxr.UsdPhysics
    catalog = catalog or load_catalog()
    out = Path(out)
    _check_suffix(out, "--usd")
    make_folder(out.parent, "--usd")
    assets_dir = out.parent / ASSETS_FOLDER
    asset_files: dict[str, Path] = {}
    for placement in spec.objects:
        if placement.asset not in asset_files:
            asset_files[placement.asset] = write_asset(catalog[placement.asset], assets_dir)

    layer = Sdf.Layer.CreateAnonymous(".usda")
    stage = Usd.Stage.Open(layer)
    _stage_metadata(stage, f"Scene '{spec.name}' of robolab_ms, written by `robolab scene export`. Frame: the "
                    "robot base is the origin, x away from the robot, y to its left, z up; the table top is "
                    "z = 0.")  # fmt: skip
    physics = UsdPhysics.Scene.Define(stage, PHYSICS_SCENE)
    physics.CreateGravityDirectionAttr(pxr.Gf.Vec3f(0.0, 0.0, -1.0))
    physics.CreateGravityMagnitudeAttr(GRAVITY)
    world = UsdGeom.Xform.Define(stage, WORLD)
    stage.SetDefaultPrim(world.GetPrim())
    pxr.Usd.ModelAPI(world.GetPrim()).SetKind("assembly")
    _set(world.GetPrim(), "scene", spec.name)
    _set(world.GetPrim(), "description", spec.description)
    _set(world.GetPrim(), "jitter_xy", spec.jitter_xy, Sdf.ValueTypeNames.Double)
    _set(world.GetPrim(), "jitter_yaw", round(math.degrees(spec.jitter_yaw), ANGLE_DECIMALS), Sdf.ValueTypeNames.Double)
    if spec.background:
        _set(world.GetPrim(), "background", spec.background)

    length, width = spec.table_size
    table = _static_box(stage, f"{WORLD}/table", (length / 2, width / 2, TABLE_HEIGHT / 2),
                        (TABLE_CENTER_XY[0], TABLE_CENTER_XY[1], -TABLE_HEIGHT / 2), spec.table_rgba[:3])  # fmt: skip
    _set(table, "role", "table")
    _set(table, "table_rgba", pxr.Gf.Vec4d(*spec.table_rgba), Sdf.ValueTypeNames.Double4)
    if spec.table_material:
        _set(table, "table_material", spec.table_material)
    pedestal = _static_box(stage, f"{WORLD}/robot_pedestal", PEDESTAL_HALF, PEDESTAL_CENTER, (0.16, 0.16, 0.17))
    _set(pedestal, "role", "robot_pedestal")

    prim_names = set(RESERVED_NAMES)
    references: dict[str, str] = {}  # body prim path -> asset path, authored once the stage is closed
    for placement in spec.objects:
        entry = catalog[placement.asset]
        prim_name = _unique(pxr.Tf.MakeValidIdentifier(placement.name), prim_names)
        body = UsdGeom.Xform.Define(stage, f"{WORLD}/{prim_name}")
        prim = body.GetPrim()
        references[prim.GetPath().pathString] = f"./{asset_files[placement.asset].relative_to(out.parent).as_posix()}"
        _set(prim, "name", placement.name)
        _set(prim, "catalog", placement.asset)
        if placement.on is not None:
            _set(prim, "rests_on", placement.on)
        if placement.level is not None:
            _set(prim, "level", placement.level, Sdf.ValueTypeNames.Int)
        q = quat_multiply(yaw_quat(placement.yaw), placement.tilt)
        body.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(pxr.Gf.Vec3d(*placement.xy, placement.z))
        body.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(pxr.Gf.Quatd(q[0], pxr.Gf.Vec3d(*q[1:])))
        rigid = UsdPhysics.RigidBodyAPI.Apply(prim)
        if placement.fixture:
            rigid.CreateKinematicEnabledAttr(True)  # as the simulator builds fixtures: placed, never pushed
        UsdPhysics.MassAPI.Apply(prim).CreateMassAttr(entry.mass)
    del stage  # the references go in without a stage, which would try to open them relative to no folder
    for path, asset in references.items():
        layer.GetPrimAtPath(path).referenceList.Prepend(Sdf.Reference(asset))

    if out.exists():
        out.unlink()
    layer.Export(str(out))
    _reload(out)
    problems = validate_stage(out)
    report = ExportReport(out, sorted(set(asset_files.values())), len(spec.objects), problems)
    if problems:
        raise RoboLabError(f"the USD stage {out} does not pass USD's checks: " + "; ".join(problems))
    return report


def _check_suffix(path: Path, option: str) -> None:
    if path.suffix.lower() not in USD_SUFFIXES:
        raise RoboLabError(f"{option} {path}: a USD file ends in {', '.join(USD_SUFFIXES)}; give e.g. "
                           f"{path.with_suffix('.usda')}")  # fmt: skip


def _stage_metadata(stage, doc: str) -> None:
    """Z up, metres, kilograms: the conventions of robolab_ms and of UsdPhysics."""
    pxr = _pxr()
    pxr.UsdGeom.SetStageUpAxis(stage, pxr.UsdGeom.Tokens.z)
    pxr.UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    pxr.UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    stage.GetRootLayer().documentation = doc


def _set(prim, key: str, value: Any, kind=None) -> None:
    """Author the custom attribute robolab:<key> (text unless `kind` says otherwise)."""
    pxr = _pxr()
    kind = kind or pxr.Sdf.ValueTypeNames.String
    prim.CreateAttribute(ATTR[key], kind, custom=True).Set(value)


def _get(prim, key: str) -> Any:
    """The value of robolab:<key> on `prim`, None when not authored."""
    attribute = prim.GetAttribute(ATTR[key])
    return attribute.Get() if attribute and attribute.HasAuthoredValue() else None


def _unique(name: str, taken: set[str]) -> str:
    candidate, index = name, 2
    while candidate in taken:
        candidate, index = f"{name}_{index}", index + 1
    taken.add(candidate)
    return candidate


def _static_box(stage, path: str, half: tuple[float, float, float], center: tuple[float, float, float],
                rgb) -> Any:  # fmt: skip
    """A box-shaped static collider (CollisionAPI, no rigid body) with its colour."""
    pxr = _pxr()
    cube = pxr.UsdGeom.Cube.Define(stage, path)
    cube.CreateSizeAttr(2.0)
    cube.CreateExtentAttr([pxr.Gf.Vec3f(-1, -1, -1), pxr.Gf.Vec3f(1, 1, 1)])
    cube.AddTranslateOp(pxr.UsdGeom.XformOp.PrecisionDouble).Set(pxr.Gf.Vec3d(*center))
    cube.AddScaleOp(pxr.UsdGeom.XformOp.PrecisionDouble).Set(pxr.Gf.Vec3d(*half))
    cube.CreateDisplayColorAttr([pxr.Gf.Vec3f(*(float(c) for c in rgb))])
    pxr.UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    return cube.GetPrim()


def _reload(path: Path) -> None:
    """Make a layer this process opened before see the file just written."""
    layer = _pxr().Sdf.Layer.Find(str(path))
    if layer is not None:
        layer.Reload(force=True)


def asset_path(entry: CatalogObject, folder: Path) -> Path:
    """Where the USD asset of a catalog object goes: text for procedural objects, binary crate for meshes."""
    return folder / f"{entry.name}{'.usda' if entry.parts else '.usdc'}"


def write_asset(entry: CatalogObject, folder: Path) -> Path:
    """Write the USD asset of a catalog object into `folder` (textures into folder/textures) and return its path."""
    pxr = _pxr()
    Sdf, Usd, UsdGeom, UsdPhysics, UsdShade = pxr.Sdf, pxr.Usd, pxr.UsdGeom, pxr.UsdPhysics, pxr.UsdShade
    folder.mkdir(parents=True, exist_ok=True)
    path = asset_path(entry, folder)
    layer = Sdf.Layer.CreateAnonymous(path.suffix)
    stage = Usd.Stage.Open(layer)
    source = entry.source.get("package") or entry.source.get("generator") or entry.source.get("kind")
    _stage_metadata(stage, f"Catalog object '{entry.name}' of robolab_ms ({entry.description}); source: {source}; "
                    f"licence: {entry.license}. Frame: z up, origin at the centre of the bottom, metres.")  # fmt: skip
    root_path = f"/{pxr.Tf.MakeValidIdentifier(entry.name)}"
    root = UsdGeom.Xform.Define(stage, root_path).GetPrim()
    stage.SetDefaultPrim(root)
    Usd.ModelAPI(root).SetKind("component")
    _set(root, "catalog", entry.name)
    _set(root, "class", entry.object_class)
    _set(root, "license", entry.license)
    root.SetDocumentation(entry.description)
    UsdGeom.Scope.Define(stage, f"{root_path}/Looks")
    physics_material = UsdShade.Material.Define(stage, f"{root_path}/Looks/physics")
    material_api = UsdPhysics.MaterialAPI.Apply(physics_material.GetPrim())
    material_api.CreateStaticFrictionAttr(entry.static_friction)
    material_api.CreateDynamicFrictionAttr(entry.dynamic_friction)
    material_api.CreateRestitutionAttr(entry.restitution)
    material_api.CreateDensityAttr(entry.density)

    def bind(prim, look, physical: bool) -> None:
        binding = UsdShade.MaterialBindingAPI.Apply(prim)
        if look is not None:
            binding.Bind(look)
        if physical:
            binding.Bind(physics_material, UsdShade.Tokens.weakerThanDescendants, "physics")

    if entry.parts:
        colours = entry.palette or (entry.rgba,)
        looks = [_preview_material(stage, f"{root_path}/Looks/tint{tint}", part_look(entry, tint))
                 for tint in range(len(colours))]  # fmt: skip
        for index, part in enumerate(entry.parts):
            prim = _part_prim(stage, f"{root_path}/part{index}", part)
            UsdPhysics.CollisionAPI.Apply(prim)
            bind(prim, looks[min(part.tint, len(looks) - 1)], True)
    else:
        UsdGeom.Scope.Define(stage, f"{root_path}/visual")
        for index, mesh in enumerate(_visual_meshes(entry, folder)):
            prim = _mesh_prim(stage, f"{root_path}/visual/mesh{index}", mesh.points, mesh.faces, mesh.normals,
                              mesh.uv)  # fmt: skip
            look = _preview_material(stage, f"{root_path}/Looks/visual{index}", mesh.look, mesh.texture, path.parent)
            bind(prim, look, False)
        collision = UsdGeom.Scope.Define(stage, f"{root_path}/collision")
        collision.CreatePurposeAttr(UsdGeom.Tokens.guide)  # not rendered: the visual meshes show the object
        for index, hull in enumerate(entry.hulls):
            points, faces = _hull_faces(hull)
            prim = _mesh_prim(stage, f"{root_path}/collision/piece{index}", points, faces)
            UsdPhysics.CollisionAPI.Apply(prim)
            UsdPhysics.MeshCollisionAPI.Apply(prim).CreateApproximationAttr(UsdPhysics.Tokens.convexHull)
            bind(prim, None, True)
    if path.exists():
        path.unlink()
    layer.Export(str(path))
    _reload(path)
    return path


def _part_prim(stage, path: str, part: Part):
    """A procedural part as a UsdGeom primitive in its pose: a Cube scaled to the box, a Sphere, or a Capsule or
    Cylinder along its x axis (as SAPIEN's)."""
    pxr = _pxr()
    UsdGeom, Gf = pxr.UsdGeom, pxr.Gf
    scale = None
    if part.shape == "box":
        gprim = UsdGeom.Cube.Define(stage, path)
        gprim.CreateSizeAttr(2.0)
        scale = Gf.Vec3d(*part.size)
        extent = (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)
    elif part.shape == "sphere":
        gprim = UsdGeom.Sphere.Define(stage, path)
        radius = part.size[0]
        gprim.CreateRadiusAttr(radius)
        extent = (-radius,) * 3, (radius,) * 3
    else:
        radius, half_length = part.size
        gprim = (UsdGeom.Capsule if part.shape == "capsule" else UsdGeom.Cylinder).Define(stage, path)
        gprim.CreateAxisAttr(UsdGeom.Tokens.x)
        gprim.CreateRadiusAttr(radius)
        gprim.CreateHeightAttr(2 * half_length)  # a capsule's height is its cylinder's, without the caps
        reach = half_length + (radius if part.shape == "capsule" else 0.0)
        extent = (-reach, -radius, -radius), (reach, radius, radius)
    gprim.CreateExtentAttr([Gf.Vec3f(*extent[0]), Gf.Vec3f(*extent[1])])
    gprim.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*part.position))
    w, x, y, z = part.rotation
    if (w, x, y, z) != (1.0, 0.0, 0.0, 0.0):
        gprim.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(w, Gf.Vec3d(x, y, z)))
    if scale is not None:
        gprim.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(scale)
    return gprim.GetPrim()


def _mesh_prim(stage, path: str, points: np.ndarray, faces: np.ndarray, normals: np.ndarray | None = None,
               uv: np.ndarray | None = None):  # fmt: skip
    """A triangle mesh (object frame) as a UsdGeom.Mesh, with vertex normals and texture coordinates when given."""
    pxr = _pxr()
    UsdGeom, Vt, Sdf = pxr.UsdGeom, pxr.Vt, pxr.Sdf
    mesh = UsdGeom.Mesh.Define(stage, path)
    points = np.asarray(points, dtype=np.float32)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(faces, dtype=np.int32).reshape(-1)))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    low, high = points.min(axis=0), points.max(axis=0)
    mesh.CreateExtentAttr([pxr.Gf.Vec3f(*map(float, low)), pxr.Gf.Vec3f(*map(float, high))])
    if normals is not None:
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(normals, dtype=np.float32)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    if uv is not None:
        primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                          UsdGeom.Tokens.vertex)  # fmt: skip
        primvar.Set(Vt.Vec2fArray.FromNumpy(np.asarray(uv, dtype=np.float32)))
    return mesh.GetPrim()


@dataclass
class _VisualMesh:
    points: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray | None
    look: Any  # robolab_ms.catalog.appearance.Look: colour, roughness, metallic
    texture: Path | None  # the texture file written into the assets folder


def _visual_meshes(entry: CatalogObject, folder: Path) -> list[_VisualMesh]:
    """The visual meshes of a mesh object in its object frame (the catalog transform applied), each with its
    texture copied into folder/textures (textured packages) or the object's look (colour only)."""
    import trimesh

    transform = entry.transform
    rotation = quat_to_matrix(transform.quaternion)
    meshes = []
    for index, file in enumerate(entry.visual_files()):
        mesh = load_mesh(str(file))
        points = transform.apply(np.asarray(mesh.vertices, dtype=np.float64))
        normals = (np.asarray(mesh.vertex_normals, dtype=np.float64) / np.asarray(transform.scale)) @ rotation.T
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        uv, texture = None, None
        visual = mesh.visual
        if entry.source.get("textured") and isinstance(visual, trimesh.visual.TextureVisuals) and visual.uv is not None:
            image_file = _texture_file(file)
            if image_file is not None or _material_image(visual) is not None:
                uv = np.asarray(visual.uv, dtype=np.float64)
                texture = _copy_texture(entry, index, image_file, _material_image(visual), folder / TEXTURES_FOLDER)
        meshes.append(_VisualMesh(points, np.asarray(mesh.faces), normals, uv, part_look(entry, 0), texture))
    return meshes


def _texture_file(mesh_file: Path) -> Path | None:
    """The image a textured OBJ names in its material file (one map_Kd), or the sidecar PNG of the same name."""
    mtl = mesh_file.with_suffix(".mtl")
    if mtl.is_file():
        maps = [line.split(None, 1)[1].strip() for line in mtl.read_text(errors="replace").splitlines()
                if line.strip().startswith("map_Kd") and len(line.split(None, 1)) == 2]  # fmt: skip
        if len(set(maps)) == 1 and (mtl.parent / maps[0]).is_file():
            return mtl.parent / maps[0]
        return None
    sidecar = mesh_file.with_suffix(".png")
    return sidecar if sidecar.is_file() else None


def _material_image(visual):
    material = getattr(visual, "material", None)
    return getattr(material, "image", None) or getattr(material, "baseColorTexture", None)


def _copy_texture(entry: CatalogObject, index: int, image_file: Path | None, image, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    if image_file is not None:
        target = folder / f"{entry.name}_{index}{image_file.suffix.lower()}"
        shutil.copyfile(image_file, target)
    else:
        target = folder / f"{entry.name}_{index}.png"
        image.save(target)
    return target


def _hull_faces(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A convex piece's hull as outward-facing triangles: (vertices, faces)."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    used = np.unique(hull.simplices)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    faces = hull.simplices.copy()
    vertices = points[used]
    centre = vertices.mean(axis=0)
    for face in faces:  # Qhull leaves the winding open: turn each triangle to face away from the centre
        a, b, c = points[face]
        if np.dot(np.cross(b - a, c - a), a - centre) < 0:
            face[1], face[2] = face[2], face[1]
    return vertices, remap[faces]


def _preview_material(stage, path: str, look, texture: Path | None = None, asset_dir: Path | None = None):
    """A UsdPreviewSurface material: the look's colour, roughness and metallic, or the texture file as its colour."""
    pxr = _pxr()
    UsdShade, Sdf, Gf = pxr.UsdShade, pxr.Sdf, pxr.Gf
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(float(look.roughness))
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(float(look.metallic))
    colour = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    if texture is None:
        colour.Set(Gf.Vec3f(*(float(c) for c in look.rgb)))
    else:
        reader = UsdShade.Shader.Define(stage, f"{path}/st")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        image = UsdShade.Shader.Define(stage, f"{path}/texture")
        image.CreateIdAttr("UsdUVTexture")
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(f"./{texture.relative_to(asset_dir).as_posix()}")
        image.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
        image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        colour.ConnectToSource(image.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


# ---------------------------------------------------------------------------------------------------- checks
STAGE_VALIDATORS = (
    "usdValidation:CompositionErrorTest", "usdValidation:StageMetadataChecker", "usdValidation:AttributeTypeMismatch",
    "usdGeomValidators:StageMetadataChecker", "usdGeomValidators:EncapsulationChecker",
    "usdUtilsValidators:MissingReferenceValidator", "usdPhysicsValidators:RigidBodyChecker",
    "usdPhysicsValidators:ColliderChecker", "usdShadeValidators:MaterialBindingApiAppliedValidator",
    "usdShadeValidators:MaterialBindingRelationships", "usdShadeValidators:ShaderSdrCompliance",
)  # fmt: skip


def validate_stage(path: Path) -> list[str]:
    """Open a USD file and check it: it composes without errors (every referenced asset found) and passes USD's
    own validators for stage metadata, geometry, physics bodies and colliders, and material bindings. Returns one
    line per finding (empty when it is good)."""
    pxr = _pxr()
    stage = pxr.Usd.Stage.Open(str(path))
    if stage is None:
        return [f"{path} does not open as a USD stage"]
    problems = [f"composition: {error}" for error in stage.GetCompositionErrors()]
    registry = pxr.UsdValidation.ValidationRegistry()
    validators = [registry.GetOrLoadValidatorByName(name) for name in STAGE_VALIDATORS]
    context = pxr.UsdValidation.ValidationContext([v for v in validators if v is not None])
    for error in context.Validate(stage):
        if error.GetType() in (pxr.UsdValidation.ValidationErrorType.Error,
                               pxr.UsdValidation.ValidationErrorType.Warn):  # fmt: skip
            problems.append(f"{error.GetName()}: {error.GetMessage()}")
    return problems


# ---------------------------------------------------------------------------------------------------- import
@dataclass
class ImportReport:
    """What `import_scene` read and wrote: the scene file, the scene as the loader reads it, and notes (bodies left
    out, bodies not at the height where they rest, scaled or re-massed bodies, composition problems)."""

    usd: Path
    scene_file: Path
    spec: SceneSpec
    notes: list[str] = field(default_factory=list)

    def line(self) -> str:
        return f"{self.scene_file}: scene '{self.spec.name}' with {len(self.spec.objects)} objects from {self.usd}"


@dataclass
class _Body:
    """One body of a USD layout, in the scene's frame (metres, z = 0 on the table top)."""

    prim: str  # its prim path
    name: str
    asset: str
    position: np.ndarray  # (3,)
    rotation: np.ndarray  # (3, 3)
    rests_on: str | None = None
    level: int | None = None
    known_support: bool = False  # rests_on / level came from robolab attributes (else inferred from the heights)


def read_mapping(file: Path, catalog: Catalog) -> dict[str, str | None]:
    """A `--map` file: a YAML mapping from a USD asset path (as written in the reference, or its file name or stem)
    or a prim name or path (shell-style patterns such as `Banana*` allowed) to a catalog object's name, or to null
    to leave such prims out."""
    fields = Fields(load_yaml(Path(file)), file)
    mapping: dict[str, str | None] = {}
    for key, value in fields.data.items():
        if not isinstance(key, str):
            raise fields.error(str(key), "is not text", "Write an asset path or prim name, quoted if need be")
        mapping[key] = None if value is None else fields.name_in(key, catalog.names(), "catalog object")
    return mapping


def _usd_error_text(error: Exception) -> str:
    """USD's first error message without its C++ location: "Error in 'Func' at line N in file F : 'message'"."""
    text = str(error).strip()
    first = text.split("Error in ")[1] if "Error in " in text else text
    message = first.split(" : ", 1)[1] if " : " in first else first
    return " ".join(message.strip().strip("'").split())[:300]


def import_scene(usd: Path, out: Path, mapping_file: Path | None = None, catalog: Catalog | None = None
                 ) -> ImportReport:  # fmt: skip
    """Read the layout of USD file `usd` into the scene file `out` (its name is the file's stem) and read that back
    with the scene loader. Bodies are prims with robolab:catalog, a RigidBodyAPI, a reference or payload, or a
    `--map` entry (`mapping_file`, see read_mapping); RoboLabError naming every prim whose catalog object is
    unknown."""
    pxr = _pxr()
    Usd, UsdGeom, UsdPhysics = pxr.Usd, pxr.UsdGeom, pxr.UsdPhysics
    catalog = catalog or load_catalog()
    usd, out = Path(usd), Path(out)
    _check_suffix(usd, "FILE")
    if out.suffix != ".yaml":
        raise RoboLabError(f"--out {out}: a scene file ends in .yaml; give e.g. {out.with_suffix('.yaml')}")
    if not usd.is_file():
        raise RoboLabError(f"{usd} is not a file. Name a USD file (.usda, .usd, .usdc)")
    mapping = read_mapping(mapping_file, catalog) if mapping_file else {}
    try:
        stage = Usd.Stage.Open(str(usd))
    except pxr.Tf.ErrorException as error:  # a file USD cannot parse
        raise RoboLabError(f"{usd} does not open as a USD stage ({_usd_error_text(error)}); give a USD file that "
                           "`usdcat` reads") from None  # fmt: skip
    if stage is None:
        raise RoboLabError(f"{usd} does not open as a USD stage")
    notes = [f"USD: {error}" for error in stage.GetCompositionErrors()]
    convert = _frame_conversion(stage, notes)
    root = stage.GetDefaultPrim() or stage.GetPseudoRoot()
    table_prim = None
    found: list[tuple[Any, str]] = []  # (prim, catalog name)
    unresolved: list[str] = []
    iterator = iter(Usd.PrimRange(root))
    for prim in iterator:
        if prim == root:
            continue
        role = _get(prim, "role")
        if role in ("table", "robot_pedestal") or (role is None and prim.GetName().lower() == "table"):
            table_prim = prim if role == "table" or (role is None and table_prim is None) else table_prim
            iterator.PruneChildren()
            continue
        references = _asset_references(prim)
        keys = [prim.GetPath().pathString, prim.GetName()] + [key for ref in references for key in _reference_keys(ref)]
        mapped, target = _look_up(mapping, keys)
        own = _get(prim, "catalog")
        if not (mapped or own or references or prim.HasAPI(UsdPhysics.RigidBodyAPI)):
            continue  # a grouping prim, a light, a camera: look inside
        iterator.PruneChildren()
        if mapped and target is None:
            notes.append(f"{prim.GetPath()}: left out (mapped to null)")
            continue
        name = target if mapped else _catalog_name(own, references, prim.GetName(), catalog)
        if name is None:
            unresolved.append(_unknown_asset(prim, own, references, catalog))
            continue
        found.append((prim, name))
    if unresolved:
        raise RoboLabError(f"{usd}: {len(unresolved)} bod{'y' if len(unresolved) == 1 else 'ies'} without a catalog "
                           "object: " + "; ".join(unresolved) + ". Map them in a YAML file given with --map "
                           "FILE.yaml (asset path, file name or prim name: catalog name, or null to leave the prim "
                           "out)")  # fmt: skip
    if not found:
        raise RoboLabError(f"{usd}: no bodies found under {root.GetPath()} (prims with robolab:catalog, a "
                           "RigidBodyAPI, a reference or payload). Map prim names to catalog objects with --map "
                           "FILE.yaml")  # fmt: skip
    table_top, table_size, table_centre = _table_geometry(table_prim, convert, notes)
    bodies = []
    taken = set(RESERVED_NAMES)
    for prim, asset in found:
        position, rotation = _world_pose(prim, convert, notes)
        position[2] -= table_top
        body = _Body(prim.GetPath().pathString, _scene_name(prim, taken), asset, position, rotation)
        if _get(prim, "name") is not None:  # a body `robolab scene export` wrote: its support is recorded
            body.rests_on, body.level, body.known_support = _get(prim, "rests_on"), _get(prim, "level"), True
        mass = prim.GetAttribute("physics:mass").Get() if prim.HasAPI(UsdPhysics.MassAPI) else None
        if mass and abs(mass - catalog[asset].mass) > 0.01 * catalog[asset].mass:
            notes.append(f"{body.prim}: mass {mass:g} kg in the USD file, {catalog[asset].mass:g} kg in the catalog "
                         f"('{asset}'); the scene uses the catalog's")  # fmt: skip
        bodies.append(body)
    names = {body.name for body in bodies}
    for body in bodies:
        if body.known_support and body.rests_on is not None and body.rests_on not in names:
            notes.append(f"{body.prim}: rests on '{body.rests_on}', which is not among the bodies; support inferred")
            body.known_support = False
    _infer_supports([body for body in bodies if not body.known_support], bodies, catalog)
    data = _scene_data(out.stem, root, table_prim, table_size, bodies, catalog, usd)
    if abs(table_centre[0] - TABLE_CENTER_XY[0]) > 1e-3 or abs(table_centre[1] - TABLE_CENTER_XY[1]) > 1e-3:
        notes.append(f"the table's centre is at x, y = {table_centre[0]:.3f}, {table_centre[1]:.3f} m in the USD "
                     f"file; scenes put it at {TABLE_CENTER_XY[0]}, {TABLE_CENTER_XY[1]} (the bodies keep their x, "
                     "y)")  # fmt: skip
    _write_scene_file(data, out, usd)
    from robolab_ms.errors import SpecError

    try:
        spec = read_scene(out, catalog)
    except SpecError as error:
        raise RoboLabError(f"the scene file written from {usd} does not pass the scene checks: {error} (fix the "
                           "layout in the USD file and import again, or edit the scene file)") from None  # fmt: skip
    for body in bodies:
        placement = spec.placement(body.name)
        rest = placement.z - (0.0 if placement.fixture else SETTLE_CLEARANCE)
        if abs(body.position[2] - rest) > SUPPORT_NOTE_GAP and abs(body.position[2] - placement.z) > SUPPORT_NOTE_GAP:
            where = f"on '{placement.on}'" if placement.on else "on the table"
            notes.append(f"{body.prim}: its origin is at z = {body.position[2]:.3f} m above the table top in the USD "
                         f"file; the scene rests it {where} at z = {rest:.3f} m")  # fmt: skip
    return ImportReport(usd, out, spec, notes)


def _frame_conversion(stage, notes: list[str]) -> np.ndarray:
    """The 4x4 matrix (column vectors) from the stage's units and up axis to metres and z up (USD reads a stage
    without metersPerUnit as centimetres, one without upAxis as Y up)."""
    pxr = _pxr()
    meters = pxr.UsdGeom.GetStageMetersPerUnit(stage)
    convert = np.diag([meters, meters, meters, 1.0])
    if meters != 1.0:
        notes.append(f"the stage's unit is {meters:g} m; lengths converted to metres")
    if pxr.UsdGeom.GetStageUpAxis(stage) == pxr.UsdGeom.Tokens.y:
        y_to_z = np.array([[1.0, 0, 0, 0], [0, 0, -1.0, 0], [0, 1.0, 0, 0], [0, 0, 0, 1.0]])  # +90 degrees about x
        convert = y_to_z @ convert
        notes.append("the stage is Y up; turned to Z up (x stays, y becomes z), bodies as modelled y up")
    return convert


def _asset_references(prim) -> list[str]:
    """The asset paths of the references and payloads authored on the prim itself (as written)."""
    paths = []
    for spec in prim.GetPrimStack():
        for items in (spec.referenceList, spec.payloadList):
            for item in (*items.explicitItems, *items.prependedItems, *items.appendedItems):
                if item.assetPath and item.assetPath not in paths:
                    paths.append(item.assetPath)
    return paths


def _reference_keys(reference: str) -> list[str]:
    """The forms of an asset path a --map key may take: as written, without a leading ./, file name, stem."""
    plain = reference[2:] if reference.startswith("./") else reference
    name = plain.rsplit("/", 1)[-1]
    return list(dict.fromkeys([reference, plain, name, name.split(".", 1)[0]]))


def _look_up(mapping: dict[str, str | None], keys: list[str]) -> tuple[bool, str | None]:
    """(found, catalog name or None) for the first key the mapping names exactly, else the first pattern matching."""
    for key in keys:
        if key in mapping:
            return True, mapping[key]
    for pattern, value in mapping.items():
        if any(fnmatch.fnmatchcase(key, pattern) for key in keys):
            return True, value
    return False, None


def _catalog_name(own: str | None, references: list[str], prim_name: str, catalog: Catalog) -> str | None:
    """The catalog object of a body: its robolab:catalog, else the stem of a referenced asset file, else its prim
    name, whichever names a catalog object."""
    candidates = [own] if own else []
    candidates += [_reference_keys(ref)[-1] for ref in references] + [prim_name]
    return next((name for name in candidates if name in catalog), None)


def _unknown_asset(prim, own: str | None, references: list[str], catalog: Catalog) -> str:
    """One prim whose catalog object is unknown, with the closest catalog names."""
    looked_for = own or (_reference_keys(references[0])[-1] if references else prim.GetName())
    where = f" (asset {references[0]})" if references else ""
    hint = did_you_mean(looked_for, catalog.names())
    return f"{prim.GetPath()}{where}: no catalog object '{looked_for}'. {hint}"


def _world_pose(prim, convert: np.ndarray, notes: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """A prim's world position (m) and rotation matrix in z-up metres; scale is dropped with a note."""
    pxr = _pxr()
    if not prim.IsA(pxr.UsdGeom.Xformable):
        raise RoboLabError(f"{prim.GetPath()}: a body must be an Xformable prim (an Xform), not a {prim.GetTypeName()}")
    matrix = pxr.UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(pxr.Usd.TimeCode.Default())
    # USD multiplies row vectors: transpose to columns. The stage's units and up axis are also the body's own
    # (an asset modelled y up in centimetres), so the conversion applies on both sides of its transform.
    world = convert @ np.array(matrix, dtype=np.float64).T @ np.linalg.inv(convert)
    linear = world[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    rotation = linear / scale
    if np.linalg.det(rotation) < 0 or np.abs(rotation.T @ rotation - np.eye(3)).max() > 1e-6:
        raise RoboLabError(f"{prim.GetPath()}: its transform mirrors or shears the body; give it a rotation, "
                           "translation and uniform scale only")  # fmt: skip
    if np.abs(scale - 1.0).max() > 1e-6:
        notes.append(f"{prim.GetPath()}: scaled by {', '.join(f'{s:g}' for s in scale)} in the USD file; "
                     "the catalog object keeps its own size")  # fmt: skip
    return world[:3, 3].copy(), rotation


def _table_geometry(table_prim, convert: np.ndarray, notes: list[str]) -> tuple[float, tuple[float, float], np.ndarray]:
    """The table top's height, the table's size (x, y) and its centre (x, y) from its world bounds; without a table
    prim the scene defaults (top at z = 0)."""
    pxr = _pxr()
    if table_prim is None:
        notes.append(f"no table prim (robolab:role \"table\" or a prim named table): the table top is taken as z = 0 "
                     f"and the table is {DEFAULT_TABLE_SIZE[0]} x {DEFAULT_TABLE_SIZE[1]} m")  # fmt: skip
        return 0.0, DEFAULT_TABLE_SIZE, np.asarray(TABLE_CENTER_XY)
    cache = pxr.UsdGeom.BBoxCache(pxr.Usd.TimeCode.Default(), [pxr.UsdGeom.Tokens.default_])
    box = cache.ComputeWorldBound(table_prim).ComputeAlignedRange()
    low, high = np.array(box.GetMin()), np.array(box.GetMax())
    corners = np.array([[x, y, z, 1.0] for x in (low[0], high[0]) for y in (low[1], high[1])
                        for z in (low[2], high[2])])  # fmt: skip
    corners = (convert @ corners.T).T[:, :3]
    low, high = corners.min(axis=0), corners.max(axis=0)
    size = tuple(round(float(v), LENGTH_DECIMALS) for v in (high - low)[:2])
    return float(high[2]), size, (low[:2] + high[:2]) / 2


def _scene_name(prim, taken: set[str]) -> str:
    """A body's scene name: robolab:name, else its prim name made of letters, digits and underscores; unique."""
    name = _get(prim, "name") or prim.GetName()
    name = "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in name) or "body"
    if name in RESERVED_NAMES:
        name = f"{name}_object"
    return _unique(name, taken)


def _infer_supports(pending: list[_Body], bodies: list[_Body], catalog: Catalog) -> None:
    """For bodies without recorded supports: what each rests on, from the heights. Each body is lowered onto the
    table and onto every other body below it (each board of a fixture); the support that puts it nearest its
    height in the USD file wins, the table on a tie."""
    from robolab_ms.scene.support import drop_height, placed_pieces

    placed = {body.name: placed_pieces(catalog[body.asset], body.rotation, body.position) for body in bodies}
    for body in pending:
        entry = catalog[body.asset]
        body.rests_on, body.level = None, None
        if entry.is_fixture:
            continue
        on_table = -float((entry.points @ body.rotation[2]).min())
        pieces = placed_pieces(entry, body.rotation, np.array([*body.position[:2], 0.0]))
        best_gap = abs(body.position[2] - on_table)
        for other in bodies:
            if other is body:
                continue
            other_entry = catalog[other.asset]
            if other_entry.is_fixture and other_entry.levels:
                options = []
                for level, top in enumerate(other_entry.levels):
                    below = [p for p in placed[other.name] if p[:, 2].max() <= other.position[2] + top + 1e-6]
                    options.append((drop_height(pieces, below), level))
            elif other_entry.is_fixture:
                continue  # a fixture without boards holds nothing
            else:
                options = [(drop_height(pieces, placed[other.name]), None)]
            for lift, level in options:
                if lift is None or lift <= on_table + 1e-3:
                    continue  # it would rest on the table there anyway
                gap = abs(body.position[2] - lift)
                if gap < best_gap:
                    best_gap, body.rests_on, body.level = gap, other.name, level


def yaw_and_tilt(rotation: np.ndarray) -> tuple[float, list[tuple[str, float]]]:
    """A rotation matrix as the scene file's yaw (degrees, about the world z, applied last) and tilt (turns about
    the object's x and y axes, applied first, in order): R = Rz(yaw) Ry(b) Rx(a). A rotation about z alone has no
    tilt, one about z and x (or y) one turn."""
    r = np.asarray(rotation, dtype=np.float64)
    if abs(r[2, 0]) < STRAIGHT and abs(r[2, 1]) < STRAIGHT:  # upright or upside down
        yaw = math.atan2(r[1, 0], r[0, 0])
        turns = [] if r[2, 2] > 0 else [("x", math.pi)]
    elif abs(r[2, 0]) < STRAIGHT:  # Rz(yaw) Rx(a): the x axis stays level
        yaw, turns = math.atan2(r[1, 0], r[0, 0]), [("x", math.atan2(r[2, 1], r[2, 2]))]
    elif abs(r[2, 1]) < STRAIGHT:  # Rz(yaw) Ry(b): the y axis stays level
        yaw, turns = math.atan2(-r[0, 1], r[1, 1]), [("y", math.atan2(-r[2, 0], r[2, 2]))]
    else:
        turns = [("x", math.atan2(r[2, 1], r[2, 2])), ("y", math.atan2(-r[2, 0], math.hypot(r[2, 1], r[2, 2])))]
        yaw = math.atan2(r[1, 0], r[0, 0])
    return _degrees(yaw), [(axis, _degrees(angle)) for axis, angle in turns]


def _degrees(angle: float) -> float:
    value = round(math.degrees(angle), ANGLE_DECIMALS) + 0.0  # + 0.0: no -0.0 in the file
    return 180.0 if value == -180.0 else value


def _scene_data(name: str, root, table_prim, table_size: tuple[float, float], bodies: list[_Body], catalog: Catalog,
                usd: Path) -> dict:  # fmt: skip
    """The scene file's content."""
    data: dict[str, Any] = {"name": name}
    description = _get(root, "description") if root.IsValid() else None
    data["description"] = description or f"Imported from {usd.name}."
    table: dict[str, Any] = {"size": list(table_size)}
    material = _get(table_prim, "table_material") if table_prim is not None else None
    if material:
        table["material"] = material
    else:
        rgba = _table_rgba(table_prim)
        colour = next((name for name, rgb in COLOR_NAMES.items()
                       if rgba[3] == 1.0 and max(abs(a - b) for a, b in zip(rgb, rgba)) < 1e-6), None)  # fmt: skip
        if colour:
            table["color"] = colour
        else:
            table["rgba"] = [round(float(c), 6) for c in rgba]
    data["table"] = table
    jitter_xy, jitter_yaw = (_get(root, "jitter_xy"), _get(root, "jitter_yaw")) if root.IsValid() else (None, None)
    if jitter_xy is not None or jitter_yaw is not None:
        data["jitter"] = {key: round(float(value), ANGLE_DECIMALS) for key, value in
                          (("xy", jitter_xy), ("yaw_deg", jitter_yaw)) if value is not None}  # fmt: skip
    background = _get(root, "background") if root.IsValid() else None
    if background:
        data["background"] = background
    items = []
    for body in bodies:
        item: dict[str, Any] = {"name": body.name, "asset": body.asset,
                                "xy": [round(float(v), LENGTH_DECIMALS) + 0.0 for v in body.position[:2]]}  # fmt: skip
        yaw, turns = yaw_and_tilt(body.rotation)
        if yaw != 0.0:
            item["yaw_deg"] = yaw
        if len(turns) == 1:
            item["tilt"] = {"axis": turns[0][0], "deg": turns[0][1]}
        elif turns:
            item["tilt"] = [{"axis": axis, "deg": deg} for axis, deg in turns]
        if body.rests_on is not None:
            item["rests_on"] = body.rests_on
            if body.level is not None:
                item["level"] = int(body.level)
        items.append(item)
    data["objects"] = items
    return data


def _table_rgba(table_prim) -> tuple[float, float, float, float]:
    if table_prim is None:
        return (*COLOR_NAMES["brown"], 1.0)
    rgba = _get(table_prim, "table_rgba")
    if rgba is not None:
        return tuple(float(c) for c in rgba)
    pxr = _pxr()
    if table_prim.IsA(pxr.UsdGeom.Gprim):
        colours = pxr.UsdGeom.Gprim(table_prim).GetDisplayColorAttr().Get()
        if colours:
            return (*(float(c) for c in colours[0]), 1.0)
    return (*COLOR_NAMES["brown"], 1.0)


def _write_scene_file(data: dict, out: Path, usd: Path) -> None:
    import yaml

    make_folder(out.parent, "--out")
    header = (f"# Imported from {usd.name} by `robolab scene import`.\n"
              "# Frame: x away from the robot, y to its left, z up; the table top is z = 0.\n")  # fmt: skip
    body = yaml.safe_dump({key: data[key] for key in ("name", "description")}, sort_keys=False, width=120,
                          allow_unicode=True)  # fmt: skip
    lines = [f"{key}: " + yaml.safe_dump(data[key], default_flow_style=True, sort_keys=False, width=200).strip()
             if isinstance(data[key], dict) else yaml.safe_dump({key: data[key]}, allow_unicode=True).strip()
             for key in ("table", "jitter", "background") if key in data]  # fmt: skip
    lines.append("objects:")
    for item in data["objects"]:
        lines.append("  - " + yaml.safe_dump(item, default_flow_style=True, sort_keys=False, width=400).strip())
    out.write_text(header + body + "\n".join(lines) + "\n", encoding="utf-8")
