"""Scene files and the ManiSkill SceneBuilder that builds them.

A scene file (scene_builders/<name>.yaml) is data: a table and catalog objects with nominal positions on it, plus
how much the positions may vary per episode. robolab_ms.scene.builder.RoboLabSceneBuilder (a ManiSkill SceneBuilder)
turns it into actors and places them each episode.
Frame: the robot base is the origin, x forward, y left, z up; the table top is z = 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from robolab_ms.catalog import COLOR_NAMES, Catalog, load_catalog
from robolab_ms.content import Fields, content_dir, load_yaml
from robolab_ms.errors import UnknownNameError

TABLE_CENTER_XY = (0.55, 0.0)
TABLE_HEIGHT = 0.75  # table top above the floor; the floor is at z = -TABLE_HEIGHT
SAFE_PLACEMENT = {"x": (0.25, 0.85), "y": (-0.45, 0.45)}  # where object positions may be declared
TILT_AXES = ("x", "y")  # object-frame axes a scene may tip an object about (to lay it on its side)
IDENTITY_QUAT = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ObjectPlacement:
    """One object of a scene: its scene-unique name, catalog entry and nominal pose on the table.

    `tilt` is the resting orientation (quaternion w, x, y, z) before the yaw about the world z: identity for an
    object standing as the catalog defines it, a quarter turn about x or y to lay it on its side."""

    name: str
    asset: str
    xy: tuple[float, float]
    yaw: float
    tilt: tuple[float, float, float, float] = IDENTITY_QUAT


@dataclass(frozen=True)
class SceneSpec:
    """A scene file, checked."""

    name: str
    description: str
    file: Path
    objects: tuple[ObjectPlacement, ...]
    table_size: tuple[float, float]
    table_rgba: tuple[float, float, float, float]
    jitter_xy: float
    jitter_yaw: float
    background: str | None = None
    table_material: str | None = None

    def object_names(self) -> list[str]:
        return [placement.name for placement in self.objects]


def read_scene(file: Path, catalog: Catalog | None = None) -> SceneSpec:
    """Read and check a scene file against the catalog."""
    catalog = catalog or load_catalog()
    fields = Fields(load_yaml(file), file)
    fields.only(["name", "description", "table", "objects", "jitter", "background"])
    from robolab_ms.scene.backgrounds import load_looks  # here: `python -m robolab_ms.scene.backgrounds` stays clean

    looks = load_looks()
    background = fields.get("background", str, None)
    if background is not None:
        fields.name_in("background", looks.backgrounds, "background")
    table = fields.sub("table", {})
    table.only(["size", "color", "rgba", "material"])
    table_material = table.get("material", str, None)
    if table_material is not None:
        table.name_in("material", looks.table_materials, "table material")
    table_color = table.get("color", str, "brown")
    if table_color not in COLOR_NAMES:
        raise table.error("color", f"'{table_color}' is not a known colour name", f"Use one of {', '.join(COLOR_NAMES)}")
    jitter = fields.sub("jitter", {})
    jitter.only(["xy", "yaw_deg"])
    objects = fields.get("objects", list)
    placements, seen = [], set()
    for index, entry in enumerate(objects):
        item = Fields(entry, file, f"objects[{index}]")
        item.only(["name", "asset", "xy", "yaw_deg", "tilt"])
        asset = item.name_in("asset", catalog.names(), "catalog object")
        name = item.get("name", str, asset)
        if name in seen:
            raise item.error("name", f"'{name}' is used twice in this scene", "Give each object a unique name")
        seen.add(name)
        xy = item.number_list("xy", 2)
        for value, axis in zip(xy, "xy"):
            low, high = SAFE_PLACEMENT[axis]
            if not low <= value <= high:
                raise item.error("xy", f"{axis} = {value} is off the usable table", f"Keep {axis} within [{low}, {high}]")
        tilt = IDENTITY_QUAT
        if item.data.get("tilt") is not None:
            if not isinstance(item.data["tilt"], dict):
                raise item.error("tilt", f"must be a mapping, got {item.data['tilt']!r}",
                                 "Write it as tilt: {axis: x, deg: 90} (axis x or y of the object, degrees)")
            tilt = read_tilt(item.sub("tilt"))
        yaw = math.radians(item.get("yaw_deg", float, 0.0))
        placements.append(ObjectPlacement(name, asset, (xy[0], xy[1]), yaw, tilt))
    name = fields.get("name", str)
    if name != file.stem:
        raise fields.error("name", f"'{name}' differs from the file name '{file.stem}'", "Make them the same")
    return SceneSpec(
        name=name,
        description=fields.get("description", str, ""),
        file=file,
        objects=tuple(placements),
        table_size=tuple(table.number_list("size", 2, [0.9, 1.2])),
        table_rgba=tuple(table.number_list("rgba", 4, [*COLOR_NAMES[table_color], 1.0])),
        jitter_xy=jitter.get("xy", float, 0.02),
        jitter_yaw=math.radians(jitter.get("yaw_deg", float, 15.0)),
        background=background,
        table_material=table_material,
    )


def read_tilt(tilt: Fields) -> tuple[float, float, float, float]:
    """The quaternion of a `tilt: {axis: x|y, deg: D}` entry: D degrees about the object's own x or y axis."""
    tilt.only(["axis", "deg"])
    axis = tilt.choice("axis", TILT_AXES)
    degrees = tilt.get("deg", float)
    if not -180.0 <= degrees <= 180.0:
        raise tilt.error("deg", f"{degrees} is not an angle in [-180, 180]", "Give the tilt in degrees, e.g. 90 to lay "
                         "the object on its side")
    half = math.radians(degrees) / 2
    return (math.cos(half), math.sin(half), 0.0, 0.0) if axis == "x" else (math.cos(half), 0.0, math.sin(half), 0.0)


def scene_names() -> list[str]:
    return sorted(path.stem for path in content_dir("scenes").glob("*.yaml"))


@lru_cache(maxsize=None)
def load_scene(name: str) -> SceneSpec:
    """A shipped scene by name."""
    path = content_dir("scenes") / f"{name}.yaml"
    if not path.exists():
        raise UnknownNameError("scene", name, scene_names())
    return read_scene(path)




def yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def quat_multiply(a: Sequence[float], b: Sequence[float]) -> list[float]:
    """The rotation b then a, as one quaternion (w, x, y, z)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]


def resting_height(points: np.ndarray, tilt: Sequence[float]) -> float:
    """The height of the object's origin that puts the lowest of its collision points (object frame, (N, 3)),
    turned by `tilt`, on the table top. A yaw about the world z does not change it."""
    w, x, y, z = tilt
    row_z = np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])  # third row of R
    return -float((points @ row_z).min())


