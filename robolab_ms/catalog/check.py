"""`robolab catalog check` and `robolab catalog sheet`: load catalog objects in SAPIEN, test them, picture them.

Each object gets its own small SAPIEN scene: a ground plane standing in for the table top (z = 0), the object
dropped just above it, lights and one camera. The check asserts what a scene needs from an object:
  - it loads (visual and collision);
  - dropped on the table it comes to rest upright and stays put (< 2 cm drift over 300 steps at 120 Hz);
  - its collision size matches the catalog's dimensions within 5 %;
  - its density is plausible (50 - 3000 kg/m^3) and SAPIEN's mass is the catalog mass;
  - it renders with visible colour or texture;
  - a container holds a small cube dropped into it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from robolab_ms.catalog.schema import Catalog, CatalogObject
from robolab_ms.physics import MAX_DRIFT_M, SIM_HZ, STABILITY_PHYSICS_STEPS

SETTLE_STEPS = 120
MAX_TILT_DEG = 15.0
SIZE_TOLERANCE = 0.05
SIZE_FLOOR = 0.06  # below 6 cm the tolerance is 3 mm (thin plates, flat tools)
MASS_TOLERANCE = 0.1  # PhysX's cooked hulls differ slightly from the hull files' volumes
DENSITY_RANGE = (50.0, 3000.0)
MIN_VISIBLE_PIXELS = 0.01  # share of the image the object must cover


@dataclass
class CheckResult:
    """The outcome of checking one object: measured values and the problems found (none when it passed)."""

    name: str
    problems: list[str] = field(default_factory=list)
    measured: dict[str, float] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return not self.problems


def _quat_z_axis(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)])


@lru_cache(maxsize=1)
def _render_device():
    """The device ManiSkill renders on here (one process can hold only one): CUDA when present, else the CPU."""
    import sapien
    import torch

    return sapien.Device("cuda" if torch.cuda.is_available() else "cpu")


def _new_scene(with_camera: bool = True, image_size: int = 128):
    import sapien

    scene = sapien.Scene([sapien.physx.PhysxCpuSystem(), sapien.render.RenderSystem(_render_device())])
    scene.set_timestep(1.0 / SIM_HZ)
    ground_material = sapien.render.RenderMaterial(base_color=[0.86, 0.86, 0.86, 1.0])
    scene.add_ground(0.0, render_material=ground_material)
    scene.set_ambient_light([0.45, 0.45, 0.45])
    scene.add_directional_light([0.3, 0.6, -1.0], [0.9, 0.9, 0.9])
    camera = scene.add_camera("view", image_size, image_size, math.radians(40), 0.01, 10.0) if with_camera else None
    return scene, camera


def _frame_camera(camera, entry: CatalogObject) -> None:
    """Point the camera at the object from the front-left, above, far enough to see all of it."""
    import sapien

    low, high = entry.bounds
    centre = (low + high) / 2
    radius = float(np.linalg.norm(high - low)) / 2
    distance = radius / math.sin(math.radians(20)) * 1.05
    direction = np.array([-0.75, 0.45, 0.55])
    direction /= np.linalg.norm(direction)
    eye = centre + direction * distance
    forward = centre - eye
    forward /= np.linalg.norm(forward)
    left = np.cross([0.0, 0.0, 1.0], forward)
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    rotation = np.stack([forward, left, up], axis=1)
    camera.set_local_pose(sapien.Pose(rotation_to_pose_matrix(rotation, eye)))


def rotation_to_pose_matrix(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = rotation
    matrix[:3, 3] = position
    return matrix


@lru_cache(maxsize=2)
def _photo_studio(image_size: int):
    """One scene and camera per image size, reused for every picture (a new camera costs seconds on lavapipe).

    The camera uses SAPIEN's default shader, whatever another part of the process chose as the global default."""
    import sapien

    previous = sapien.render.get_camera_shader_dir()
    sapien.render.set_camera_shader_dir("default")
    try:
        return _new_scene(image_size=image_size)
    finally:
        sapien.render.set_camera_shader_dir(previous)


def render_object(entry: CatalogObject, image_size: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """An RGB image (uint8, H x W x 3) of the object resting at the origin, and its pixel mask."""
    import sapien

    scene, camera = _photo_studio(image_size)
    actor = entry.build(scene, entry.name, sapien.Pose(p=[0.0, 0.0, 0.0]))
    try:
        _frame_camera(camera, entry)
        rgb = _take_picture(scene, camera)
    finally:
        scene.remove_actor(actor)
    empty = _take_picture(scene, camera)  # the same view without the object gives its mask
    mask = np.abs(rgb.astype(np.int16) - empty.astype(np.int16)).max(axis=2) > 4
    return rgb, mask


def _take_picture(scene, camera) -> np.ndarray:
    scene.update_render()
    camera.take_picture()
    picture = camera.get_picture("Color")[..., :3]  # float or 8-bit, depending on the process's picture format
    if picture.dtype == np.uint8:
        return picture
    return (np.clip(picture, 0, 1) * 255).astype(np.uint8)


def _collision_size(body) -> np.ndarray:
    """Exact extent (x, y, z) of the collision shapes SAPIEN built, read back from the shapes themselves."""
    import sapien

    lows, highs = [], []
    for shape in body.collision_shapes:
        matrix = shape.local_pose.to_transformation_matrix()
        rotation, centre = matrix[:3, :3], matrix[:3, 3]
        if isinstance(shape, sapien.physx.PhysxCollisionShapeConvexMesh):
            points = (np.asarray(shape.vertices) * np.asarray(shape.scale)) @ rotation.T + centre
            lows.append(points.min(axis=0))
            highs.append(points.max(axis=0))
            continue
        if isinstance(shape, sapien.physx.PhysxCollisionShapeBox):
            half = np.abs(rotation) @ np.asarray(shape.half_size)
        elif isinstance(shape, sapien.physx.PhysxCollisionShapeSphere):
            half = np.full(3, shape.radius)
        else:  # capsule or cylinder along the local x axis
            axis = np.abs(rotation[:, 0])
            radial = (
                1.0
                if isinstance(shape, sapien.physx.PhysxCollisionShapeCapsule)
                else np.sqrt(np.clip(1 - axis**2, 0, 1))
            )
            half = axis * shape.half_length + shape.radius * radial
        lows.append(centre - half)
        highs.append(centre + half)
    return np.max(highs, axis=0) - np.min(lows, axis=0)


def check_object(entry: CatalogObject, render: bool = True) -> CheckResult:
    """Run every check on one catalog object."""
    import sapien

    result = CheckResult(entry.name)
    try:
        scene, _ = _new_scene(with_camera=False)
        lift = 0.005
        actor = entry.build(scene, entry.name, sapien.Pose(p=[0.0, 0.0, lift]))
    except Exception as error:  # noqa: BLE001 - any load failure is the finding
        result.problems.append(f"does not load: {error}")
        return result
    body = actor.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent)
    size = _collision_size(body)
    expected = np.asarray(entry.recorded_dimensions or (entry.exact_bounds[1] - entry.exact_bounds[0]))
    error = float(np.max(np.abs(size - expected) / np.maximum(expected, SIZE_FLOOR)))
    result.measured["size_error"] = error
    if error > SIZE_TOLERANCE:
        result.problems.append(
            f"collision size {np.round(size, 4).tolist()} differs from the catalog's "
            f"{np.round(expected, 4).tolist()} by {error:.0%} (> {SIZE_TOLERANCE:.0%})"
        )
    result.measured["density"] = entry.density
    if not DENSITY_RANGE[0] <= entry.density <= DENSITY_RANGE[1]:
        result.problems.append(f"density {entry.density:.0f} kg/m^3 is outside {DENSITY_RANGE}: check the mass")
    if abs(body.mass - entry.mass) > MASS_TOLERANCE * entry.mass:
        result.problems.append(f"SAPIEN mass {body.mass:.3f} kg differs from the catalog mass {entry.mass} kg")
    for _ in range(SETTLE_STEPS):
        scene.step()
    settled = actor.pose
    for _ in range(STABILITY_PHYSICS_STEPS):
        scene.step()
    final = actor.pose
    drift = float(np.linalg.norm(np.asarray(final.p) - np.asarray(settled.p)))
    start_drop = float(np.linalg.norm(np.asarray(settled.p[:2])))
    tilt = math.degrees(math.acos(float(np.clip(_quat_z_axis(np.asarray(final.q))[2], -1, 1))))
    result.measured.update(drift=drift, tilt_deg=tilt, slide=start_drop)
    if drift > MAX_DRIFT_M or start_drop > MAX_DRIFT_M:
        result.problems.append(f"does not stay put: moved {max(drift, start_drop) * 100:.1f} cm")
    if tilt > MAX_TILT_DEG:
        result.problems.append(f"does not rest upright: tilted {tilt:.0f} degrees")
    if entry.is_container:
        held = _holds_small_object(entry)
        result.measured["holds"] = float(held)
        if not held:
            result.problems.append("a small cube dropped into it does not stay inside")
    if render:
        rgb, mask = render_object(entry)
        coverage = float(mask.mean())
        result.measured["coverage"] = coverage
        if coverage < MIN_VISIBLE_PIXELS:
            result.problems.append(f"hardly visible when rendered ({coverage:.1%} of the image)")
        elif float(rgb[mask].mean()) < 8:
            result.problems.append("renders black (no colour or texture)")
    return result


def _holds_small_object(entry: CatalogObject) -> bool:
    import sapien

    scene, _ = _new_scene(with_camera=False)
    container = entry.build(scene, entry.name, sapien.Pose())
    interior = np.asarray(entry.interior)
    half = float(min(0.012, interior[:2].min() * 0.2, max(interior[2] * 0.4, 0.004)))
    low, high = entry.bounds
    centre = (low[:2] + high[:2]) / 2
    probe = scene.create_actor_builder()
    probe.add_box_collision(half_size=[half] * 3, density=500)
    probe.add_box_visual(half_size=[half] * 3)
    probe.initial_pose = sapien.Pose(p=[*centre, high[2] + half + 0.01])
    cube = probe.build(name="probe")
    for _ in range(SETTLE_STEPS + 120):
        scene.step()
    position = np.asarray(cube.pose.p) - np.asarray(container.pose.p)
    inside_xy = np.all(np.abs(position[:2] - centre) <= interior[:2] / 2 + half)
    return bool(inside_xy and position[2] < high[2] + half)


def check_catalog(
    catalog: Catalog, names: list[str] | None = None, render: bool = True, progress: Callable[[str], None] = print
) -> list[CheckResult]:
    """Check the named objects (all when None); reports each as it finishes."""
    names = names or catalog.names()
    results = []
    for index, name in enumerate(names, 1):
        result = check_object(catalog[name], render=render)
        results.append(result)
        status = "ok" if result.passed else "FAIL: " + "; ".join(result.problems)
        progress(f"[{index}/{len(names)}] {name}: {status}")
    return results


MIN_TILE = 16  # pixels: smaller tiles show nothing recognisable
SHAPE_BADGE_COLOURS = {"scanned": (40, 140, 60), "modelled": (40, 90, 170), "primitive": (120, 120, 120)}


def draw_shape_badge(
    draw, font, corner: tuple[int, int], shape: str, colour: tuple[int, int, int] | None = None
) -> None:
    """The object's shape kind (scanned, modelled, primitive) in white on a coloured tag at a tile's top left;
    `colour` for a label that is not one of the kinds."""
    left, top, right, bottom = draw.textbbox((0, 0), shape, font=font)
    x, y = corner
    draw.rectangle((x, y, x + right - left + 3, y + bottom + 2), fill=colour or SHAPE_BADGE_COLOURS[shape])
    draw.text((x + 2, y + 1), shape, fill=(255, 255, 255), font=font)


def contact_sheet(
    catalog: Catalog,
    out: Path,
    names: list[str] | None = None,
    tile: int = 112,
    columns: int = 16,
    progress: Callable[[str], None] = print,
) -> Path:
    """Render every object (or `names`) into one labelled grid image (PNG) at `out`: each tile names the object and
    tags its shape kind (scanned green, modelled blue, primitive grey)."""
    from PIL import Image, ImageDraw, ImageFont

    from robolab_ms.errors import RoboLabError, make_folder

    if tile < MIN_TILE:
        raise RoboLabError(f"--tile {tile}: give at least {MIN_TILE} pixels")
    if out.suffix.lower() != ".png":
        raise RoboLabError(f"--out {out}: the contact sheet is a PNG image; give a file name ending in .png")
    make_folder(out.parent, "--out")  # before the rendering, which takes a while
    names = names or catalog.names()
    label_height = 14
    rows = math.ceil(len(names) / columns)
    sheet = Image.new("RGB", (columns * tile, rows * (tile + label_height)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    font = ImageFont.load_default()
    for index, name in enumerate(names):
        rgb, _ = render_object(catalog[name], image_size=tile)
        x, y = (index % columns) * tile, (index // columns) * (tile + label_height)
        sheet.paste(Image.fromarray(rgb), (x, y))
        label = name if len(name) <= 19 else name[:18] + "~"
        draw.text((x + 2, y + tile + 1), label, fill=(0, 0, 0), font=font)
        draw_shape_badge(draw, font, (x, y), catalog[name].shape)
        if (index + 1) % columns == 0 or index + 1 == len(names):
            progress(f"rendered {index + 1}/{len(names)}")
    try:
        sheet.save(out, optimize=True)
    except OSError as error:
        raise RoboLabError(
            f"--out {out}: cannot write the image ({error.strerror or error}); choose a file you can write"
        ) from None
    return out
