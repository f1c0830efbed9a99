"""Scenes to USD: a scene file written as a USD stage (UsdGeom geometry, UsdPhysics bodies), with one asset file
per catalog object.

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
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.catalog import Catalog, CatalogObject, load_catalog
from robolab_ms.catalog.appearance import part_look
from robolab_ms.catalog.meshes import load_mesh
from robolab_ms.catalog.procedural import Part, quat_multiply, quat_to_matrix, yaw_quat
from robolab_ms.errors import RoboLabError, make_folder
from robolab_ms.scene.spec import (
    RESERVED_NAMES,
    ROBOT_PEDESTAL_CENTER,
    ROBOT_PEDESTAL_HALF_SIZE,
    TABLE_CENTER_XY,
    TABLE_HEIGHT,
    SceneSpec,
)
from robolab_ms.scene.usd_stage import (
    ANGLE_DECIMALS,
    PHYSICS_SCENE,
    WORLD,
    check_suffix,
    pxr_modules,
    unique_name,
    validate_stage,
    write_attribute,
)

ASSETS_FOLDER = "assets"  # beside the exported scene file: one USD file per catalog object
TEXTURES_FOLDER = "textures"  # inside the assets folder
GRAVITY = 9.81  # m/s^2


@dataclass
class ExportReport:
    """What `export_scene` wrote: the scene file, the asset files and the bodies."""

    usd: Path
    assets: list[Path]
    bodies: int
    problems: list[str] = field(default_factory=list)  # validation findings (empty for a good stage)

    def line(self) -> str:
        return (
            f"{self.usd}: {self.bodies} bodies, {len(self.assets)} asset file(s) in {self.usd.parent / ASSETS_FOLDER}"
        )


def export_scene(spec: SceneSpec, out: Path, catalog: Catalog | None = None) -> ExportReport:
    """Write scene `spec` as the USD stage `out` (.usda, .usd or .usdc) with its assets folder beside it; the
    written stage is opened and validated (RoboLabError listing what is wrong)."""
    pxr = pxr_modules()
    Sdf, Usd, UsdGeom, UsdPhysics = pxr.Sdf, pxr.Usd, pxr.UsdGeom, pxr.UsdPhysics
    catalog = catalog or load_catalog()
    out = Path(out)
    check_suffix(out, "--usd")
    make_folder(out.parent, "--usd")
    assets_dir = out.parent / ASSETS_FOLDER
    asset_files: dict[str, Path] = {}
    for placement in spec.objects:
        if placement.asset not in asset_files:
            asset_files[placement.asset] = write_asset(catalog[placement.asset], assets_dir)

    layer = Sdf.Layer.CreateAnonymous(".usda")
    stage = Usd.Stage.Open(layer)
    _stage_metadata(
        stage,
        f"Scene '{spec.name}' of robolab_ms, written by `robolab scene export`. Frame: the "
        "robot base is the origin, x away from the robot, y to its left, z up; the table top is "
        "z = 0.",
    )
    physics = UsdPhysics.Scene.Define(stage, PHYSICS_SCENE)
    physics.CreateGravityDirectionAttr(pxr.Gf.Vec3f(0.0, 0.0, -1.0))
    physics.CreateGravityMagnitudeAttr(GRAVITY)
    world = UsdGeom.Xform.Define(stage, WORLD)
    stage.SetDefaultPrim(world.GetPrim())
    pxr.Usd.ModelAPI(world.GetPrim()).SetKind("assembly")
    write_attribute(world.GetPrim(), "scene", spec.name)
    write_attribute(world.GetPrim(), "description", spec.description)
    write_attribute(world.GetPrim(), "jitter_xy", spec.jitter_xy, Sdf.ValueTypeNames.Double)
    write_attribute(
        world.GetPrim(), "jitter_yaw", round(math.degrees(spec.jitter_yaw), ANGLE_DECIMALS), Sdf.ValueTypeNames.Double
    )
    if spec.background:
        write_attribute(world.GetPrim(), "background", spec.background)

    length, width = spec.table_size
    table = _static_box(
        stage,
        f"{WORLD}/table",
        (length / 2, width / 2, TABLE_HEIGHT / 2),
        (TABLE_CENTER_XY[0], TABLE_CENTER_XY[1], -TABLE_HEIGHT / 2),
        spec.table_rgba[:3],
    )
    write_attribute(table, "role", "table")
    write_attribute(table, "table_rgba", pxr.Gf.Vec4d(*spec.table_rgba), Sdf.ValueTypeNames.Double4)
    if spec.table_material:
        write_attribute(table, "table_material", spec.table_material)
    pedestal = _static_box(
        stage, f"{WORLD}/robot_pedestal", ROBOT_PEDESTAL_HALF_SIZE, ROBOT_PEDESTAL_CENTER, (0.16, 0.16, 0.17)
    )
    write_attribute(pedestal, "role", "robot_pedestal")

    prim_names = set(RESERVED_NAMES)
    references: dict[str, str] = {}  # body prim path -> asset path, authored once the stage is closed
    for placement in spec.objects:
        entry = catalog[placement.asset]
        prim_name = unique_name(pxr.Tf.MakeValidIdentifier(placement.name), prim_names)
        body = UsdGeom.Xform.Define(stage, f"{WORLD}/{prim_name}")
        prim = body.GetPrim()
        references[prim.GetPath().pathString] = f"./{asset_files[placement.asset].relative_to(out.parent).as_posix()}"
        write_attribute(prim, "name", placement.name)
        write_attribute(prim, "catalog", placement.asset)
        if placement.on is not None:
            write_attribute(prim, "rests_on", placement.on)
        if placement.level is not None:
            write_attribute(prim, "level", placement.level, Sdf.ValueTypeNames.Int)
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


def _stage_metadata(stage, doc: str) -> None:
    """Z up, metres, kilograms: the conventions of robolab_ms and of UsdPhysics."""
    pxr = pxr_modules()
    pxr.UsdGeom.SetStageUpAxis(stage, pxr.UsdGeom.Tokens.z)
    pxr.UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    pxr.UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    stage.GetRootLayer().documentation = doc


def _static_box(stage, path: str, half: tuple[float, float, float], center: tuple[float, float, float], rgb) -> Any:
    """A box-shaped static collider (CollisionAPI, no rigid body) with its colour."""
    pxr = pxr_modules()
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
    layer = pxr_modules().Sdf.Layer.Find(str(path))
    if layer is not None:
        layer.Reload(force=True)


def asset_path(entry: CatalogObject, folder: Path) -> Path:
    """Where the USD asset of a catalog object goes: text for procedural objects, binary crate for meshes."""
    return folder / f"{entry.name}{'.usda' if entry.parts else '.usdc'}"


def write_asset(entry: CatalogObject, folder: Path) -> Path:
    """Write the USD asset of a catalog object into `folder` (textures into folder/textures) and return its path."""
    pxr = pxr_modules()
    Sdf, Usd, UsdGeom, UsdPhysics, UsdShade = pxr.Sdf, pxr.Usd, pxr.UsdGeom, pxr.UsdPhysics, pxr.UsdShade
    folder.mkdir(parents=True, exist_ok=True)
    path = asset_path(entry, folder)
    layer = Sdf.Layer.CreateAnonymous(path.suffix)
    stage = Usd.Stage.Open(layer)
    source = entry.source.get("package") or entry.source.get("generator") or entry.source.get("kind")
    _stage_metadata(
        stage,
        f"Catalog object '{entry.name}' of robolab_ms ({entry.description}); source: {source}; "
        f"licence: {entry.license}. Frame: z up, origin at the centre of the bottom, metres.",
    )
    root_path = f"/{pxr.Tf.MakeValidIdentifier(entry.name)}"
    root = UsdGeom.Xform.Define(stage, root_path).GetPrim()
    stage.SetDefaultPrim(root)
    Usd.ModelAPI(root).SetKind("component")
    write_attribute(root, "catalog", entry.name)
    write_attribute(root, "class", entry.object_class)
    write_attribute(root, "license", entry.license)
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
        looks = [
            _preview_material(stage, f"{root_path}/Looks/tint{tint}", part_look(entry, tint))
            for tint in range(len(colours))
        ]
        for index, part in enumerate(entry.parts):
            prim = _part_prim(stage, f"{root_path}/part{index}", part)
            UsdPhysics.CollisionAPI.Apply(prim)
            bind(prim, looks[min(part.tint, len(looks) - 1)], True)
    else:
        UsdGeom.Scope.Define(stage, f"{root_path}/visual")
        for index, mesh in enumerate(_visual_meshes(entry, folder)):
            prim = _mesh_prim(stage, f"{root_path}/visual/mesh{index}", mesh.points, mesh.faces, mesh.normals, mesh.uv)
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
    pxr = pxr_modules()
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


def _mesh_prim(
    stage,
    path: str,
    points: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray | None = None,
    uv: np.ndarray | None = None,
):
    """A triangle mesh (object frame) as a UsdGeom.Mesh, with vertex normals and texture coordinates when given."""
    pxr = pxr_modules()
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
        primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
        )
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
    """The visual meshes of a mesh or modelled object in its object frame (the catalog transform applied), each
    with its texture copied into folder/textures (textured packages) or its look (colour only)."""
    import trimesh

    if entry.is_modelled:  # generated surfaces, already in the object frame, each with its colour's look
        return [
            _VisualMesh(
                s.mesh.vertices,
                s.mesh.triangles,
                s.mesh.normals,
                None,
                part_look(entry, s.tint, s.kind, s.rgb, s.shade),
                None,
            )
            for s in entry.model.surfaces
        ]
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
        maps = [
            line.split(None, 1)[1].strip()
            for line in mtl.read_text(errors="replace").splitlines()
            if line.strip().startswith("map_Kd") and len(line.split(None, 1)) == 2
        ]
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
    pxr = pxr_modules()
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
