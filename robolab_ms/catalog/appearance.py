"""How objects and room surfaces look: image textures we generate, physically plausible materials, UV meshes.

Every procedural part and every packaged mesh without its own texture gets an image texture made here from its
catalog colour: wood grain for blocks and wooden things, printed labels for cans and bottles, box print, Rubik's
stickers, ceramic glaze, brushed metal, fruit skin, plastic, keys and screens. Textures are small (128-256 px),
made with numpy from a seed derived from their name, so every process renders the same image; each is made once
per process. Materials carry roughness and metallic values that fit the material (metal, ceramic, plastic, wood).

SAPIEN's cylinder visual has no texture coordinates, so cylinders, the floor and the room backdrop are triangle
meshes made here, attached by `VisualMeshBuilder`.

A scene without a render system (ManiSkill's `render_backend="none"`) has no look at all: `scene_renders` is the one
check that everything making textures, materials, lights, environment maps or visual shapes asks first.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:
    import sapien

TEXTURE_SIZE = 128


def scene_renders(scene: Any) -> bool:
    """Whether `scene` (a ManiSkill scene or a plain SAPIEN scene) has a render system. Without one (ManiSkill's
    `render_backend="none"`) only what the physics needs is built: no textures, materials, visual shapes, lights,
    environment map or cameras."""
    if hasattr(scene, "can_render"):
        return bool(scene.can_render())
    try:
        _ = scene.render_system
    except RuntimeError:  # SAPIEN: "no system with name [render] is added to scene"
        return False
    return True


class LookedEntry(Protocol):
    """What an object's look is chosen from: the fields of a catalog object (robolab_ms.catalog.schema.CatalogObject)
    that name, class and colour it."""

    name: str
    object_class: str
    source: dict[str, Any]
    colors: tuple[str, ...]
    rgba: tuple[float, float, float, float]
    palette: tuple[tuple[float, float, float, float], ...]


# ---------------------------------------------------------------------------------------------------- materials
@dataclass(frozen=True)
class Look:
    """The appearance of one surface: a texture kind, a base colour (linear 0-1 RGB), roughness and metallic."""

    kind: str
    rgb: tuple[float, float, float]
    roughness: float
    metallic: float = 0.0


# kind -> (roughness, metallic)
SURFACES = {
    "plastic": (0.45, 0.0), "rubber": (0.85, 0.0), "painted_wood": (0.55, 0.0), "wood": (0.65, 0.0),
    "ceramic": (0.22, 0.0), "metal": (0.3, 1.0), "dark_metal": (0.4, 0.9), "skin": (0.45, 0.0), "banana": (0.5, 0.0),
    "baked": (0.8, 0.0), "label": (0.35, 0.0), "print": (0.5, 0.0), "sticker": (0.3, 0.0), "keys": (0.5, 0.0),
    "screen": (0.08, 0.0), "paper": (0.85, 0.0), "sponge": (0.95, 0.0), "plant": (0.6, 0.0), "glass": (0.05, 0.0),
    "book": (0.6, 0.0),
}  # fmt: skip

WOODEN_WORDS = ("wood", "crate", "tray", "shelf", "spice_rack", "mallet")


def _rgb_of(entry: LookedEntry, tint: int) -> tuple[float, float, float]:
    colours = entry.palette or (entry.rgba,)
    return tuple(float(c) for c in colours[min(tint, len(colours) - 1)][:3])


def _colour_name(entry: LookedEntry, tint: int) -> str:
    if not entry.colors:
        return ""
    return entry.colors[min(tint, len(entry.colors) - 1)]


def surface_kind(entry: LookedEntry, tint: int = 0) -> str:
    """Which texture kind a part of `entry` with colour index `tint` gets (the whole mesh for mesh objects: tint 0)."""
    name, cls = entry.name, entry.object_class
    generator = entry.source.get("generator", "mesh")
    colour = _colour_name(entry, tint)
    wooden = any(word in name for word in WOODEN_WORDS) or (colour == "tan" and cls in ("utensil", "tool"))
    if colour in ("silver", "gold") and name not in ("wine_glass",):
        return "metal"
    if name == "wine_glass":
        return "glass"
    if generator == "puzzle_cube":
        return "plastic" if tint == 0 else "sticker"
    if cls in ("fruit", "vegetable"):
        if "banana" in name:
            return "banana"
        return "skin" if tint == 0 else "plant"
    if wooden:
        return "wood"
    if cls == "block":
        return "painted_wood"
    if cls == "can" or (generator == "can"):
        return "label" if tint == 0 else "metal"
    if cls == "bottle":
        return "label" if tint == 0 and generator != "mesh" else "plastic"
    if cls == "box" or generator == "carton":
        if name == "sponge":
            return "sponge"
        return "print" if tint == 0 else "plastic"
    if cls == "food":
        if generator == "box" and "bread" not in name:
            return "print"
        return "baked"
    if cls in ("container", "tableware"):
        vessels = ("bowl", "cup", "mug", "cylinder", "mesh")
        if generator in vessels and not any(w in name for w in ("pail", "bin", "basket")):
            if "paper" in name:
                return "paper"
            return "ceramic" if tint == 0 else "plastic"
        return "plastic"
    if cls == "electronics":
        if tint == 1:
            return "keys" if any(w in name for w in ("keyboard", "remote")) else "screen"
        return "plastic"
    if generator == "flat_device":  # books
        return "book" if tint == 0 else "paper"
    if cls == "tool" and generator == "hammer" and tint == 1:
        return "dark_metal"
    if cls == "tool" and generator == "drill" and tint == 1:
        return "rubber"
    if cls == "furniture":
        return "wood"
    return "plastic"


def part_look(
    entry: LookedEntry,
    tint: int = 0,
    kind: str | None = None,
    rgb: tuple[float, float, float] | None = None,
    shade: float = 1.0,
) -> Look:
    """The look of a part (or of a whole untextured mesh) of a catalog object. A modelled surface may name its own
    texture `kind` and colour `rgb`, and darken (`shade` below 1) or lighten its colour."""
    kind = kind or surface_kind(entry, tint)
    roughness, metallic = SURFACES[kind]
    colour = rgb if rgb is not None else _rgb_of(entry, tint)
    return Look(kind, tuple(float(min(1.0, c * shade)) for c in colour), roughness, metallic)


def render_material(look: Look, face: int = 0) -> sapien.render.RenderMaterial:
    """A SAPIEN material with the look's generated texture (the base colour is in the texture)."""
    import sapien

    material = sapien.render.RenderMaterial(
        base_color=[1.0, 1.0, 1.0, 1.0], roughness=look.roughness, metallic=look.metallic
    )
    material.base_color_texture = render_texture(look.kind, _quantise(look.rgb), face)
    return material


def _quantise(rgb: tuple[float, float, float]) -> tuple[float, float, float]:
    return tuple(round(float(c), 3) for c in rgb)


@lru_cache(maxsize=None)
def render_texture(kind: str, rgb: tuple[float, float, float], face: int = 0) -> sapien.render.RenderTexture2D:
    """The texture of `kind` in colour `rgb`, made once per process."""
    import sapien

    image = make_texture(kind, rgb, face)
    rgba = np.concatenate([image, np.full((*image.shape[:2], 1), 255, np.uint8)], axis=2)
    return sapien.render.RenderTexture2D(rgba, "R8G8B8A8Unorm", mipmap_levels=4, srgb=True)


@lru_cache(maxsize=None)
def texture_from_file(path: str) -> sapien.render.RenderTexture2D:
    """A texture image file, loaded once per process."""
    import sapien

    return sapien.render.RenderTexture2D(path, mipmap_levels=4, srgb=True)


# ---------------------------------------------------------------------------------------------------- textures
def _rng(*key) -> np.random.Generator:
    digest = hashlib.sha256(repr(key).encode()).digest()
    return np.random.default_rng(int.from_bytes(digest[:8], "little"))


def noise(size: int, cells: int, rng: np.random.Generator, octaves: int = 3) -> np.ndarray:
    """Smooth fractal value noise in [0, 1], tiling, (size, size)."""
    from PIL import Image

    total = np.zeros((size, size))
    weight = 0.0
    for octave in range(octaves):
        count = cells * 2**octave
        grid = rng.random((count, count))
        grid = np.tile(grid, (3, 3))  # tile so the resize wraps
        big = Image.fromarray((grid * 255).astype(np.uint8)).resize((size * 3, size * 3), Image.BICUBIC)
        layer = np.asarray(big, dtype=float)[size : 2 * size, size : 2 * size] / 255
        total += layer / 2**octave
        weight += 1 / 2**octave
    total /= weight
    return (total - total.min()) / max(total.max() - total.min(), 1e-6)


def _to_srgb(linear: np.ndarray) -> np.ndarray:
    """Catalog colours are display colours already; clip and convert to uint8."""
    return (np.clip(linear, 0, 1) * 255).astype(np.uint8)


def _shade(rgb, amount: np.ndarray) -> np.ndarray:
    """An image of colour `rgb` brightened or darkened by `amount` (H, W), in -1..1."""
    base = np.asarray(rgb, dtype=float)[None, None, :]
    amount = amount[..., None]
    return np.where(amount >= 0, base + (1 - base) * amount, base * (1 + amount))


def _text_bars(image: np.ndarray, box: tuple[int, int, int, int], colour, rng: np.random.Generator) -> None:
    """Rows of short dark bars that read as printed text inside box (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = box
    y = y0
    while y + 3 <= y1:
        x = x0
        while x < x1:
            word = int(rng.integers(4, 14))
            image[y : y + 3, x : min(x + word, x1)] = colour
            x += word + 3
        y += 7


def _luma(rgb) -> float:
    return 0.3 * rgb[0] + 0.59 * rgb[1] + 0.11 * rgb[2]


def make_texture(kind: str, rgb: tuple[float, float, float], face: int = 0) -> np.ndarray:
    """A (N, N, 3) uint8 texture of `kind` in colour `rgb`."""
    n = TEXTURE_SIZE
    rng = _rng(kind, rgb, face)
    yy, xx = np.mgrid[0:n, 0:n] / n
    if kind in ("plastic", "rubber", "screen", "glass"):
        grain = noise(n, 16, rng, 2) - 0.5
        strength = {"plastic": 0.06, "rubber": 0.12, "screen": 0.03, "glass": 0.02}[kind]
        image = _shade(rgb, grain * strength)
        if kind == "screen":
            image = _shade((0.05, 0.06, 0.08), 0.25 * (1 - yy) * (xx > 0.03) * (xx < 0.97) + grain * 0.05)
        return _to_srgb(image)
    if kind in ("wood", "painted_wood"):
        warp = noise(n, 4, rng, 3)
        rings = np.sin((yy * 18 + warp * 3.0) * math.pi * 2) * 0.5 + 0.5
        fibres = noise(n, 32, rng, 2)
        amount = (rings - 0.5) * (0.22 if kind == "wood" else 0.09) + (fibres - 0.5) * 0.08
        return _to_srgb(_shade(rgb, amount))
    if kind == "ceramic":
        speckle = (rng.random((n, n)) > 0.995) * -0.25
        glaze = (noise(n, 6, rng, 2) - 0.5) * 0.05
        return _to_srgb(_shade(rgb, glaze + speckle))
    if kind in ("metal", "dark_metal"):
        brushed = np.repeat(rng.random((n, 1)), n, axis=1)
        brushed = 0.6 * brushed + 0.4 * noise(n, 8, rng, 2)
        colour = rgb if kind == "metal" else tuple(c * 0.35 for c in rgb)
        return _to_srgb(_shade(colour, (brushed - 0.5) * 0.18))
    if kind in ("skin", "plant", "baked"):
        mottle = noise(n, 6, rng, 3) - 0.5
        pores = (rng.random((n, n)) > 0.985) * (0.12 if kind == "skin" else 0.2)
        strength = {"skin": 0.22, "plant": 0.25, "baked": 0.35}[kind]
        image = _shade(rgb, mottle * strength + pores)
        if kind == "skin":  # a faint second hue, as on apples and citrus
            blush = np.clip(noise(n, 3, rng, 2) - 0.6, 0, 1)[..., None] * 0.3
            image = image * (1 - blush) + image * np.array([1.05, 0.85, 0.7]) * blush
        return _to_srgb(image)
    if kind == "banana":
        image = _shade(rgb, (noise(n, 6, rng, 3) - 0.5) * 0.15)
        freckles = (noise(n, 24, rng, 1) > 0.93) & (rng.random((n, n)) > 0.4)
        image[freckles] = image[freckles] * np.array([0.75, 0.6, 0.4])
        return _to_srgb(image)
    if kind == "sponge":
        pores = noise(n, 24, rng, 2)
        image = _shade(rgb, (pores - 0.5) * 0.3)
        image[pores < 0.25] *= 0.6
        return _to_srgb(image)
    if kind == "paper":
        return _to_srgb(_shade(rgb, (noise(n, 32, rng, 2) - 0.5) * 0.06))
    image = _to_srgb(_shade(rgb, (noise(n, 8, rng, 2) - 0.5) * 0.05))
    dark = np.array([20, 20, 25], np.uint8) if _luma(rgb) > 0.35 else np.array([240, 240, 235], np.uint8)
    if kind == "sticker":  # one face of a Rubik's cube: 3 x 3 stickers on black
        cell = (np.minimum(xx * 3 % 1, yy * 3 % 1) < 0.09) | (np.maximum(xx * 3 % 1, yy * 3 % 1) > 0.91)
        image[cell] = (18, 18, 18)
        return image
    if kind == "keys":  # a grid of keys with dark gaps
        image[:] = _to_srgb(np.asarray(rgb)[None, None, :] * 0.8)
        gap = ((xx * 14) % 1 < 0.15) | ((yy * 6) % 1 < 0.2)
        image[gap] = (12, 12, 14)
        return image
    if kind == "label":  # a can or bottle label (u goes around): colour, a white band with a logo and text
        white = np.array([235, 232, 225], np.uint8)
        band = (yy > 0.3) & (yy < 0.72)
        image[band] = white
        image[(np.abs(yy - 0.22) < 0.02) | (np.abs(yy - 0.8) < 0.02)] = dark
        for centre in (0.25, 0.75):
            logo = (xx - centre) ** 2 + ((yy - 0.45) * 1.2) ** 2 < 0.012
            image[logo & band] = _to_srgb(np.asarray(rgb))
        _text_bars(image, (int(0.08 * n), int(0.58 * n), int(0.92 * n), int(0.7 * n)), (40, 40, 45), rng)
        return image
    if kind in ("print", "book"):  # box print or a book cover: a panel with a logo and text
        x0, y0, x1, y1 = (int(0.12 * n), int(0.15 * n), int(0.88 * n), int(0.62 * n))
        panel = np.array([240, 236, 228], np.uint8) if kind == "print" else _to_srgb(np.asarray(rgb) * 0.7)
        image[y0:y1, x0:x1] = panel
        accent = _to_srgb(np.asarray(rgb) * 0.6 + np.asarray((0.9, 0.75, 0.2)) * 0.4)
        logo = (xx - 0.5) ** 2 + (yy - 0.3) ** 2 < 0.008
        image[logo] = accent
        _text_bars(
            image, (x0 + 6, int(0.45 * n), x1 - 6, y1 - 4), (35, 35, 40) if kind == "print" else (230, 225, 210), rng
        )
        image[int(0.75 * n) : int(0.8 * n), int(0.12 * n) : int(0.6 * n)] = dark
        return image
    return image


# ---------------------------------------------------------------------------------------------------- meshes
@dataclass(frozen=True)
class TriangleMesh:
    """Vertices (N, 3), triangles (M, 3), normals (N, 3) and texture coordinates (N, 2)."""

    vertices: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray

    def render_shape(self, material: sapien.render.RenderMaterial) -> sapien.render.RenderShapeTriangleMesh:
        import sapien

        return sapien.render.RenderShapeTriangleMesh(
            self.vertices.astype(np.float32),
            self.triangles.astype(np.uint32),
            self.normals.astype(np.float32),
            self.uvs.astype(np.float32),
            material,
        )


@lru_cache(maxsize=None)
def cylinder_mesh(radius: float, half_length: float, segments: int = 32) -> TriangleMesh:
    """A closed cylinder along x (SAPIEN's cylinder axis); u goes around the side, caps are mapped flat."""
    angles = np.linspace(0, 2 * math.pi, segments + 1)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    vertices, normals, uvs, triangles = [], [], [], []
    for side in (-1, 1):  # side wall
        vertices.append(np.column_stack([np.full(segments + 1, side * half_length), radius * ring]))
        normals.append(np.column_stack([np.zeros(segments + 1), ring]))
        uvs.append(np.column_stack([angles / (2 * math.pi), np.full(segments + 1, (side + 1) / 2)]))
    j = np.arange(segments)
    triangles.append(np.column_stack([j, j + segments + 1, j + 1]))
    triangles.append(np.column_stack([j + 1, j + segments + 1, j + segments + 2]))
    offset = 2 * (segments + 1)
    for side in (-1, 1):  # caps: centre and ring
        centre = np.array([[side * half_length, 0.0, 0.0]])
        vertices.append(
            np.concatenate([centre, np.column_stack([np.full(segments + 1, side * half_length), radius * ring])])
        )
        normals.append(np.tile([side, 0.0, 0.0], (segments + 2, 1)))
        uvs.append(np.concatenate([[[0.5, 0.5]], 0.5 + 0.5 * ring]))
        if side > 0:
            triangles.append(np.column_stack([np.full(segments, offset), offset + 1 + j, offset + 2 + j]))
        else:
            triangles.append(np.column_stack([np.full(segments, offset), offset + 2 + j, offset + 1 + j]))
        offset += segments + 2
    return TriangleMesh(
        np.concatenate(vertices), np.concatenate(triangles), np.concatenate(normals), np.concatenate(uvs)
    )


@lru_cache(maxsize=None)
def box_mesh(half_size: tuple[float, float, float]) -> TriangleMesh:
    """A box with each face mapped to the whole texture (SAPIEN's box visual maps each face to a part of it)."""
    vertices, normals, uvs, triangles = [], [], [], []
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u_axis, v_axis = [(1, 2), (2, 0), (0, 1)][axis]
            if sign < 0:
                u_axis, v_axis = v_axis, u_axis  # keep the winding counter-clockwise seen from outside
            face = np.zeros((4, 3))
            face[:, axis] = sign * half_size[axis]
            face[:, u_axis] = (corners[:, 0] * 2 - 1) * half_size[u_axis]
            face[:, v_axis] = (corners[:, 1] * 2 - 1) * half_size[v_axis]
            normal = np.zeros(3)
            normal[axis] = sign
            start = len(vertices) * 4
            vertices.append(face)
            normals.append(np.tile(normal, (4, 1)))
            uvs.append(np.column_stack([corners[:, 0], 1 - corners[:, 1]]))
            triangles.append(np.array([[start, start + 1, start + 2], [start, start + 2, start + 3]]))
    return TriangleMesh(
        np.concatenate(vertices), np.concatenate(triangles), np.concatenate(normals), np.concatenate(uvs)
    )


def plane_mesh(size_x: float, size_y: float, tile: float) -> TriangleMesh:
    """A flat rectangle in the xy plane facing +z, centred at the origin; the texture repeats every `tile` metres."""
    hx, hy = size_x / 2, size_y / 2
    vertices = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], dtype=float)
    uvs = vertices[:, :2] / tile
    return TriangleMesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]), np.tile([0.0, 0.0, 1.0], (4, 1)), uvs)


def panorama_sphere(radius: float, rings: int = 48, segments: int = 96) -> TriangleMesh:
    """A sphere seen from inside, with equirectangular texture coordinates: u = azimuth, v = polar angle from +z.

    u = 0.5 looks along +x, u grows towards -y (clockwise seen from above), as environment maps are mapped."""
    theta = np.linspace(0, math.pi, rings + 1)  # from +z down
    phi = np.linspace(0, 2 * math.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    direction = np.stack([-np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    uvs = np.stack([p / (2 * math.pi), t / math.pi], axis=-1).reshape(-1, 2)
    i, j = np.meshgrid(np.arange(rings), np.arange(segments), indexing="ij")
    a = (i * (segments + 1) + j).ravel()
    b = a + segments + 1
    triangles = np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])  # facing inwards
    return TriangleMesh(direction * radius, triangles, -direction, uvs)


def sidecar_texture_material(path: Path) -> sapien.render.RenderMaterial | None:
    """For a textured OBJ without a material file whose texture lies beside it under the same name (as LIBERO's
    MuJoCo objects ship them): a material with that texture; else None (the mesh's own materials apply)."""
    import sapien

    image = path.with_suffix(".png")
    if path.suffix.lower() != ".obj" or path.with_suffix(".mtl").is_file() or not image.is_file():
        return None
    material = sapien.render.RenderMaterial(base_color=[1.0, 1.0, 1.0, 1.0], roughness=0.3)
    material.base_color_texture = texture_from_file(str(image))
    return material


PROJECTED_TEXTURE_SIZE = 0.08  # m: one texture repeat on a mesh with projected texture coordinates


@lru_cache(maxsize=None)
def projected_mesh(path: str, scale: tuple[float, float, float]) -> TriangleMesh:
    """A packaged mesh without texture coordinates, scaled to metres, with smooth normals (split at creases) and
    coordinates projected on each vertex normal's dominant axis."""
    import trimesh

    mesh = trimesh.load(path, force="mesh", process=True)
    mesh.apply_transform(np.diag([*scale, 1.0]))
    smooth = mesh.smooth_shaded
    vertices = np.asarray(smooth.vertices, dtype=float)
    normals = np.asarray(smooth.vertex_normals, dtype=float)
    axis = np.argmax(np.abs(normals), axis=1)
    keep = np.array([[1, 2], [0, 2], [0, 1]])[axis]
    uvs = np.take_along_axis(vertices, keep, axis=1) / PROJECTED_TEXTURE_SIZE
    return TriangleMesh(vertices, np.asarray(smooth.faces), normals, uvs)


# ---------------------------------------------------------------------------------------------------- builder
def _with_meshes(base: type) -> type:
    """An actor builder class (SAPIEN's or ManiSkill's) that can also attach triangle meshes made here."""

    class VisualMeshBuilder(base):
        def __init__(self) -> None:
            super().__init__()
            self.mesh_visuals: list = []

        def add_visual_mesh(self, mesh: TriangleMesh, material, pose=None):
            """Attach `mesh` with `material` at `pose` (actor frame)."""
            import sapien

            self.mesh_visuals.append((mesh, material, pose or sapien.Pose()))
            return self

        def build_render_component(self):
            component = super().build_render_component()
            for mesh, material, pose in self.mesh_visuals:
                shape = mesh.render_shape(material)
                shape.local_pose = pose
                component.attach(shape)
            return component

        def build_entity(self):
            import sapien

            if self.visual_records or not self.mesh_visuals or not scene_renders(self.scene):
                return super().build_entity()
            entity = sapien.Entity()  # only generated meshes: the base builders would skip the render component
            entity.add_component(self.build_render_component())
            entity.add_component(self.build_physx_component())
            entity.name = self.name
            return entity

    return VisualMeshBuilder


@lru_cache(maxsize=None)
def _builder_class(maniskill: bool) -> type:
    if maniskill:
        from mani_skill.utils.building.actor_builder import ActorBuilder
    else:
        from sapien.wrapper.actor_builder import ActorBuilder
    return _with_meshes(ActorBuilder)


def visual_mesh_builder(scene):
    """An actor builder for `scene` (a ManiSkill scene or a plain SAPIEN scene) with `add_visual_mesh`."""
    import sapien

    builder = _builder_class(not isinstance(scene, sapien.Scene))()
    builder.set_scene(scene)
    return builder


def has_image_texture(actor) -> bool:
    """True when every visual part of a built actor (first sub-scene) has a base-colour image texture."""
    import sapien

    entity = actor._objs[0]
    component = entity.find_component_by_type(sapien.render.RenderBodyComponent)
    if component is None:
        return False
    materials = []
    for shape in component.render_shapes:
        if isinstance(shape, sapien.render.RenderShapeTriangleMesh):
            materials += [part.material for part in shape.parts]
        else:
            materials.append(shape.material)
    return bool(materials) and all(m.base_color_texture is not None for m in materials)
