"""Scene files: the reader that checks one (`read_scene`) into a `SceneSpec`, and where scenes are found by name
(`scene_files`, `load_scene`).

A scene file (scene_builders/<name>.yaml) is data: a table and catalog objects with nominal positions on it, plus
how much the positions may vary per episode. robolab_ms.scene.builder.RoboLabSceneBuilder (a ManiSkill SceneBuilder)
turns it into actors and places them each episode.
Frame: the robot base is the origin, x forward, y left, z up; the table top is z = 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull

from robolab_ms.catalog import COLOR_NAMES, Catalog, CatalogObject, load_catalog
from robolab_ms.catalog.procedural import IDENTITY as IDENTITY_QUAT
from robolab_ms.catalog.procedural import quat_multiply, quat_to_matrix, yaw_quat
from robolab_ms.content import Fields, content_files, load_yaml
from robolab_ms.errors import UnknownNameError
from robolab_ms.scene.outlines import outline_inside, outline_points, outlines_overlap

TABLE_CENTER_XY = (0.55, 0.0)
TABLE_HEIGHT = 0.75  # table top above the floor; the floor is at z = -TABLE_HEIGHT
SAFE_PLACEMENT = {"x": (0.25, 0.85), "y": (-0.45, 0.45)}  # where object positions may be declared
# the relations left of, right of, in front of and behind as seen from the robot: unit (x, y) directions
DIRECTIONS = {"left_of": (0.0, 1.0), "right_of": (0.0, -1.0), "in_front_of": (-1.0, 0.0), "behind": (1.0, 0.0)}
TILT_AXES = ("x", "y")  # object-frame axes a scene may tip an object about (to lay it on its side)
JITTER_YAW_STEP_DEG = 5.0  # the yaw range of the jitter is checked at steps this fine
DEFAULT_TABLE_SIZE = (0.9, 1.2)  # x (depth, away from the robot), y (width)
DEFAULT_TABLE_COLOR = "brown"  # a table without color, rgba or material (robolab_ms.scene.room: it shows wood)
ROBOT_PEDESTAL_HALF_SIZE = (0.15, 0.15, TABLE_HEIGHT / 2)  # the robot's stand: a box from the floor to the robot base
ROBOT_PEDESTAL_CENTER = (-0.08, 0.0, -TABLE_HEIGHT / 2 - 0.001)
# the pedestal reaches this far forward; the table starts in front of it
ROBOT_PEDESTAL_FRONT_X = round(ROBOT_PEDESTAL_CENTER[0] + ROBOT_PEDESTAL_HALF_SIZE[0], 6)
MAX_TABLE_SIZE = (2 * (TABLE_CENTER_XY[0] - ROBOT_PEDESTAL_FRONT_X), 2.0)
MAX_JITTER_XY = 0.1  # m
OVERLAP_TOLERANCE = 0.001  # m: outlines may touch or overlap this much
RESERVED_NAMES = ("table", "robot_pedestal")  # the environment's own bodies
SETTLE_CLEARANCE = 0.002  # m: objects start this far above where they rest, and drop into place


@dataclass(frozen=True)
class ObjectPlacement:
    """One object of a scene: its scene-unique name, catalog entry and nominal pose on the table.

    `tilt` is the resting orientation (quaternion w, x, y, z) before the yaw about the world z: identity for an
    object standing as the catalog defines it, a quarter turn about x or y to lay it on its side. `on` (scene field
    `rests_on`) names the object it starts on or in (a cube on a cube, a keyboard leaning into a bin); it moves
    with that support. A fixture (a catalog object marked `fixture`, such as a shelf) stays where the scene file
    puts it; `level` (scene field, with `rests_on` a fixture) is the board of the fixture the object stands on,
    0 the lowest."""

    name: str
    asset: str
    xy: tuple[float, float]
    yaw: float
    tilt: tuple[float, float, float, float] = IDENTITY_QUAT
    on: str | None = None  # the scene object it rests on (None: the table)
    z: float = 0.0  # height of its origin at the nominal place: resting on its support, plus SETTLE_CLEARANCE
    fixture: bool = False  # a fixture of the catalog: built kinematic, never jittered
    level: int | None = None  # with `on` a fixture: the index of the fixture's board it stands on (0 the lowest)


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

    def placement(self, name: str) -> ObjectPlacement:
        """The placement of the object called `name`."""
        for placement in self.objects:
            if placement.name == name:
                return placement
        raise UnknownNameError("object", name, self.object_names())

    def supports(self, name: str) -> list[str]:
        """The objects `name` rests on, nearest first (empty for an object on the table)."""
        chain = []
        support = self.placement(name).on
        while support is not None:
            chain.append(support)
            support = self.placement(support).on
        return chain

    def base(self, name: str) -> str:
        """The object at the bottom of `name`'s pile, which stands on the table or on a fixture (`name` itself when
        it does, or is a fixture): the jitter moves a pile as one piece with its base, and leaves fixtures still."""
        for support in self.supports(name):
            if self.placement(support).fixture:
                break
            name = support
        return name


def read_scene(file: Path, catalog: Catalog | None = None) -> SceneSpec:
    """Read and check a scene file against the catalog: every field, and that the objects lie on the table without
    overlapping at their nominal places (one wholly inside a container's outline may)."""
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
        for key in ("color", "rgba"):
            if table.has(key):
                raise table.error(
                    key,
                    "is given together with material, whose texture replaces the colour",
                    "Give either a material or a colour",
                )
    if table.has("color") and table.has("rgba"):
        raise table.error("rgba", "is given together with color, which it would replace", "Give only one of them")
    table_color = table.choice("color", COLOR_NAMES, DEFAULT_TABLE_COLOR)
    table_rgba = table.number_list("rgba", 4, [*COLOR_NAMES[table_color], 1.0], low=0.0, high=1.0)
    table_size = table.number_list(
        "size", 2, list(DEFAULT_TABLE_SIZE), low=0.0, high=MAX_TABLE_SIZE[1], above=True, unit="m"
    )
    if table_size[0] > MAX_TABLE_SIZE[0]:
        raise table.error(
            "size[0]",
            f"the table would be {table_size[0]:g} m deep and reach the robot's pedestal",
            f"Keep size[0] (along x, away from the robot) at most {MAX_TABLE_SIZE[0]:g} m",
        )
    jitter = fields.sub("jitter", {})
    jitter.only(["xy", "yaw_deg"])
    jitter_xy = jitter.number("xy", 0.0, MAX_JITTER_XY, 0.02, unit="m")
    jitter_yaw = math.radians(jitter.number("yaw_deg", 0.0, 180.0, 15.0, unit="degrees"))
    objects = fields.get("objects", list)
    if not objects:
        raise fields.error("objects", "is empty", "Place at least one catalog object")
    placements: list[ObjectPlacement] = []
    items: list[Fields] = []
    seen: dict[str, int] = {}
    for index, entry in enumerate(objects):
        item = Fields(entry, file, f"objects[{index}]")
        items.append(item)
        item.only(["name", "asset", "xy", "yaw_deg", "tilt", "rests_on", "level"])
        asset = item.name_in("asset", catalog.names(), "catalog object")
        name = item.get("name", str, asset)
        if not name.replace("_", "").isalnum() or not name.isascii():
            raise item.error(
                "name", f"'{name}' has characters other than letters, digits and underscores", "Use a name like red_mug"
            )
        if name in RESERVED_NAMES:
            raise item.error(
                "name",
                f"'{name}' is the name of the environment's own {name.replace('_', ' ')}",
                "Give the object another name",
            )
        if name in seen:
            raise item.error(
                "name",
                f"'{name}' is used twice in this scene (also by objects[{seen[name]}])",
                "Give each object a unique name",
            )
        seen[name] = index
        xy = item.number_list("xy", 2)
        for value, axis in zip(xy, "xy"):
            low, high = SAFE_PLACEMENT[axis]
            if not low <= value <= high:
                raise item.error(
                    "xy", f"{axis} = {value} is off the usable table", f"Keep {axis} within [{low}, {high}]"
                )
        tilt = IDENTITY_QUAT
        if item.has("tilt"):
            value = item.data["tilt"]
            if isinstance(value, list) and value:  # turns one after the other
                for turn in range(len(value)):
                    tilt = tuple(quat_multiply(read_tilt(Fields(value[turn], file, item.where(f"tilt[{turn}]"))), tilt))
            elif isinstance(value, dict):
                tilt = read_tilt(item.sub("tilt"))
            else:
                raise item.error(
                    "tilt",
                    f"must be a mapping or a list of them, got {value!r}",
                    "Write it as tilt: {axis: x, deg: 90} (axis x or y of the object, degrees), or a "
                    "list of such turns",
                )
        yaw = math.radians(item.number("yaw_deg", -360.0, 360.0, 0.0, unit="degrees"))
        placements.append(ObjectPlacement(name, asset, (xy[0], xy[1]), yaw, tilt, fixture=catalog[asset].is_fixture))
    name = fields.get("name", str)
    if name != file.stem:
        raise fields.error("name", f"'{name}' differs from the file name '{file.stem}'", "Make them the same")
    placements = read_supports(items, placements)
    placements = read_levels(items, placements, catalog)
    placements = rest_heights(items, placements, catalog)
    check_fixture_places(items, placements, catalog, jitter_xy, jitter_yaw)
    check_layout(fields, placements, catalog, (table_size[0], table_size[1]))
    check_jittered_footprints(fields, placements, catalog, (table_size[0], table_size[1]), jitter_xy, jitter_yaw)
    return SceneSpec(
        name=name,
        description=fields.get("description", str, ""),
        file=file,
        objects=tuple(placements),
        table_size=(table_size[0], table_size[1]),
        table_rgba=tuple(table_rgba),
        jitter_xy=jitter_xy,
        jitter_yaw=jitter_yaw,
        background=background,
        table_material=table_material,
    )


def read_supports(items: Sequence[Fields], placements: Sequence[ObjectPlacement]) -> list[ObjectPlacement]:
    """The placements with their `rests_on` field: another object of the scene, not the object itself, and no loop
    of supports (a on b on a)."""
    names = [placement.name for placement in placements]
    supported = []
    for item, placement in zip(items, placements):
        if not item.has("rests_on"):
            supported.append(placement)
            continue
        support = item.get("rests_on", str)
        if support == "table":
            raise item.error(
                "rests_on",
                "names the table, which every object without `rests_on` stands on",
                "Leave `rests_on` out to set the object on the table",
            )
        support = item.name_in("rests_on", names, "object of this scene")
        if support == placement.name:
            raise item.error("rests_on", f"'{support}' cannot rest on itself", "Name the object it rests on or in")
        supported.append(replace(placement, on=support))
    support_of = {placement.name: placement.on for placement in supported}
    for item, placement in zip(items, supported):
        chain = [placement.name]
        while support_of[chain[-1]] is not None:
            chain.append(support_of[chain[-1]])
            if chain[-1] == placement.name:
                raise item.error(
                    "rests_on",
                    f"the supports form a loop ({' on '.join(chain)})",
                    "Let the bottom object of the pile stand on the table (leave its `rests_on` out)",
                )
    return supported


def read_levels(
    items: Sequence[Fields], placements: Sequence[ObjectPlacement], catalog: Catalog
) -> list[ObjectPlacement]:
    """The placements with their `level` field: the board of the fixture they rest on, needed when the fixture has
    several levels. A fixture stands on the table, upright."""
    by_name = {placement.name: placement for placement in placements}
    leveled = []
    for item, placement in zip(items, placements):
        if placement.fixture:
            if placement.on is not None:
                raise item.error(
                    "rests_on", f"'{placement.name}' is a fixture, which stands on the table", "Leave `rests_on` out"
                )
            if placement.tilt != IDENTITY_QUAT:
                raise item.error("tilt", f"'{placement.name}' is a fixture, which stands upright", "Leave `tilt` out")
        support = by_name[placement.on] if placement.on is not None else None
        if support is None or not support.fixture:
            if item.has("level"):
                raise item.error(
                    "level",
                    "is given for an object that does not rest on a fixture (a shelf)",
                    "Leave `level` out, or name a fixture in `rests_on`",
                )
            leveled.append(placement)
            continue
        levels = catalog[support.asset].levels
        if not levels:
            raise item.error(
                "rests_on",
                f"fixture '{support.name}' has no boards to stand on",
                "Set the object on the table, or on another object",
            )
        if not item.has("level") and len(levels) > 1:
            raise item.error(
                "level",
                f"is missing: fixture '{support.name}' has {len(levels)} levels",
                f"Give level: 0 (the lowest board) to {len(levels) - 1} (the highest)",
            )
        level = item.get("level", int, 0)
        if not 0 <= level < len(levels):
            raise item.error(
                "level",
                f"{level} is not a level of fixture '{support.name}', which has {len(levels)}",
                f"Give a level from 0 (the lowest board) to {len(levels) - 1} (the highest)",
            )
        leveled.append(replace(placement, level=level))
    return leveled


def rest_heights(
    items: Sequence[Fields], placements: Sequence[ObjectPlacement], catalog: Catalog
) -> list[ObjectPlacement]:
    """The placements with `z`, the height of each origin that rests the object on the table top or,
    with `rests_on`, lowered straight down onto its support (supports first), plus SETTLE_CLEARANCE."""
    from robolab_ms.scene.support import drop_height, placed_pieces

    by_name = {placement.name: index for index, placement in enumerate(placements)}
    heights: dict[str, float] = {}

    def height(index: int) -> float:
        placement = placements[index]
        if placement.name in heights:
            return heights[placement.name]
        entry = catalog[placement.asset]
        rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(placement.yaw), placement.tilt)))
        on_table = resting_height(entry.points, placement.tilt)
        z = on_table
        if placement.on is not None:
            below = by_name[placement.on]
            support = placements[below]
            support_rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(support.yaw), support.tilt)))
            support_pieces = placed_pieces(
                catalog[support.asset], support_rotation, np.array([*support.xy, height(below)])
            )
            pieces = placed_pieces(entry, rotation, np.array([*placement.xy, 0.0]))
            item = items[index]
            if placement.level is not None:  # lowered onto that board, past the ones above it
                board_top = height(below) + catalog[support.asset].levels[placement.level]
                support_pieces = [piece for piece in support_pieces if piece[:, 2].max() <= board_top + 1e-6]
                boards = [piece for piece in support_pieces if piece[:, 2].max() >= board_top - 1e-6]
                lift = drop_height(pieces, support_pieces)
                on_board = drop_height(pieces, boards)
                if lift is None or on_board is None or on_board < lift - 1e-4:
                    raise item.error(
                        "xy",
                        f"'{placement.name}' is not over level {placement.level} of "
                        f"'{placement.on}' (seen from above it misses that board)",
                        "Move it over the board, or give another level",
                    )
            else:
                lift = drop_height(pieces, support_pieces)
            if lift is None:
                raise item.error(
                    "xy",
                    f"'{placement.name}' is not over its support '{placement.on}' (seen from above "
                    "their outlines do not meet)",
                    f"Move it over '{placement.on}', or leave `rests_on` out",
                )
            if lift < on_table - SETTLE_CLEARANCE:
                raise item.error(
                    "xy",
                    f"'{placement.name}' would rest on the table before it touches its support "
                    f"'{placement.on}' ({(on_table - lift) * 100:.1f} cm above it there)",
                    f"Move it over '{placement.on}', or leave `rests_on` out",
                )
            z = max(on_table, lift)
        heights[placement.name] = z + (0.0 if placement.fixture else SETTLE_CLEARANCE)  # a fixture cannot settle
        return heights[placement.name]

    return [replace(placement, z=height(index)) for index, placement in enumerate(placements)]


def check_fixture_places(
    items: Sequence[Fields],
    placements: Sequence[ObjectPlacement],
    catalog: Catalog,
    jitter_xy: float,
    jitter_yaw: float,
) -> None:
    """An object standing on a fixture's level stays clear of the rest of the fixture (its posts, the board above)
    and has its centre over its board, at its nominal place and at the extremes of the jitter (which moves it on
    the fixture; the fixture itself stays)."""
    from robolab_ms.scene.support import overlap_depth, placed_pieces

    by_name = {placement.name: placement for placement in placements}
    for item, placement in zip(items, placements):
        if placement.level is None:
            continue
        fixture = by_name[placement.on]
        fixture_entry = catalog[fixture.asset]
        fixture_rotation = quat_to_matrix(tuple(yaw_quat(fixture.yaw)))
        fixture_pieces = placed_pieces(fixture_entry, fixture_rotation, np.array([*fixture.xy, fixture.z]))
        board_top = fixture.z + fixture_entry.levels[placement.level]
        boards = [
            piece
            for piece in fixture_pieces
            if abs(piece[:, 2].max() - board_top) <= 1e-6 and ConvexHull(piece[:, :2]).volume > 0
        ]
        entry = catalog[placement.asset]
        centre = (entry.bounds[0] + entry.bounds[1]) / 2
        for dx in (-jitter_xy, 0.0, jitter_xy):
            for dy in (-jitter_xy, 0.0, jitter_xy):
                for turn in (-jitter_yaw, 0.0, jitter_yaw):
                    rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(placement.yaw + turn), placement.tilt)))
                    position = np.array([placement.xy[0] + dx, placement.xy[1] + dy, placement.z])
                    where = (
                        "at its place"
                        if dx == dy == turn == 0.0
                        else (
                            f"at some poses the jitter allows (moved {dx * 100:+.1f}, {dy * 100:+.1f} cm, turned "
                            f"{math.degrees(turn):+.0f} degrees)"
                        )
                    )
                    depth = overlap_depth(placed_pieces(entry, rotation, position), fixture_pieces)
                    if depth > OVERLAP_TOLERANCE:
                        raise item.error(
                            "xy",
                            f"'{placement.name}' on level {placement.level} of '{fixture.name}' "
                            f"reaches {depth * 100:.1f} cm into the fixture (a post or the board above) "
                            f"{where}",
                            "Move it further onto the board, choose a level with more room "
                            "above, or lower the scene's jitter",
                        )
                    xy = (rotation @ centre + position)[:2]
                    if not any(
                        outline_inside(xy[None], board[ConvexHull(board[:, :2]).vertices, :2], 0.0) for board in boards
                    ):
                        raise item.error(
                            "xy",
                            f"'{placement.name}' has its centre off level {placement.level} of "
                            f"'{fixture.name}' {where}",
                            "Move it further onto the board, or lower the scene's jitter",
                        )


def read_tilt(tilt: Fields) -> tuple[float, float, float, float]:
    """The quaternion of a `tilt: {axis: x|y, deg: D}` entry: D degrees about the x or y axis (of the object as it
    stands before this turn and the yaw; a list of entries turns about the same fixed axes, one after the other)."""
    tilt.only(["axis", "deg"])
    axis = tilt.choice("axis", TILT_AXES)
    if tilt.has("deg") and isinstance(tilt.data["deg"], (int, float)) and not -180 <= tilt.data["deg"] <= 180:
        raise tilt.error(
            "deg",
            f"{tilt.data['deg']} is not an angle in [-180, 180]",
            "Give the tilt in degrees, e.g. 90 to lay the object on its side",
        )
    degrees = tilt.number("deg", -180.0, 180.0, unit="degrees")
    half = math.radians(degrees) / 2
    return (math.cos(half), math.sin(half), 0.0, 0.0) if axis == "x" else (math.cos(half), 0.0, math.sin(half), 0.0)


def footprint(entry: CatalogObject, placement: ObjectPlacement) -> np.ndarray:
    """The outline of an object at its nominal place seen from above: corners (K, 2) of a convex polygon in world
    x, y, counter-clockwise."""
    rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(placement.yaw), placement.tilt)))
    points = outline_points(entry) @ rotation[:2].T + np.asarray(placement.xy)
    return points[ConvexHull(points).vertices]


def check_layout(
    fields: Fields, placements: Sequence[ObjectPlacement], catalog: Catalog, table_size: tuple[float, float]
) -> None:
    """Objects lie wholly on the table and apart at their nominal places; an object may stand wholly inside the
    outline of a container (the simulator lifts it onto the container's floor in the first steps), and one resting
    on another (`rests_on`) may overlap the objects of its pile."""
    outlines = [footprint(catalog[placement.asset], placement) for placement in placements]
    support_of = {placement.name: placement.on for placement in placements}

    def below(name: str) -> set[str]:
        chain = set()
        while support_of[name] is not None:
            name = support_of[name]
            chain.add(name)
        return chain

    piles = [below(placement.name) for placement in placements]
    for size, default_size, axis, centre in zip(table_size, DEFAULT_TABLE_SIZE, range(2), TABLE_CENTER_XY):
        low, high = centre - size / 2, centre + size / 2
        for index, (placement, outline) in enumerate(zip(placements, outlines)):
            reach = outline[:, axis].min(), outline[:, axis].max()
            if reach[0] >= low and reach[1] <= high:
                continue
            letter = "xy"[axis]
            where = f"{letter} {reach[0]:.3f}..{reach[1]:.3f} m"
            if centre - default_size / 2 <= reach[0] and reach[1] <= centre + default_size / 2:
                raise fields.error(
                    f"table.size[{axis}]",
                    f"the table ({letter} {low:.3f}..{high:.3f} m) is too small "
                    f"for objects[{index}] '{placement.name}' ({where})",
                    f"Make size[{axis}] larger or move the objects closer together",
                )
            raise fields.error(
                f"objects[{index}].xy",
                f"'{placement.name}' reaches past the table's edge ({where}; "
                f"the table spans {letter} {low:.3f}..{high:.3f} m)",
                "Move it further in",
            )
    lows = np.array([outline.min(axis=0) for outline in outlines])
    highs = np.array([outline.max(axis=0) for outline in outlines])
    boxes_meet = (
        (np.minimum(highs[:, None], highs[None]) - np.maximum(lows[:, None], lows[None])) > OVERLAP_TOLERANCE
    ).all(axis=-1)
    for later in range(len(placements)):
        for earlier in range(later):
            if not boxes_meet[later, earlier]:  # apart already by their bounding boxes
                continue
            depth = outlines_overlap(outlines[earlier], outlines[later])
            if depth <= OVERLAP_TOLERANCE:
                continue
            if placements[earlier].name in piles[later] or placements[later].name in piles[earlier]:
                continue  # one rests on the other
            if placements[earlier].on or placements[later].on:  # one is lifted off the table: apart in height?
                depth = _depth_in_space(placements[earlier], placements[later], catalog)
                if depth <= OVERLAP_TOLERANCE:
                    continue
            if any(
                catalog[placements[outer].asset].is_container
                and outline_inside(outlines[inner], outlines[outer], OVERLAP_TOLERANCE)
                for inner, outer in ((later, earlier), (earlier, later))
            ):
                continue
            raise fields.error(
                f"objects[{later}].xy",
                f"'{placements[later].name}' overlaps objects[{earlier}] "
                f"'{placements[earlier].name}' by {depth * 100:.1f} cm at their nominal places",
                "Move them apart (leave a few centimetres for the fingers), or place the object "
                "wholly inside a container's outline",
            )


def _depth_in_space(first: ObjectPlacement, second: ObjectPlacement, catalog: Catalog) -> float:
    """How deep two objects at their nominal poses (heights included) interpenetrate (m; 0 or less: apart)."""
    from robolab_ms.scene.support import overlap_depth, placed_pieces

    def pieces(placement: ObjectPlacement) -> list[np.ndarray]:
        rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(placement.yaw), placement.tilt)))
        return placed_pieces(catalog[placement.asset], rotation, np.array([*placement.xy, placement.z]))

    return overlap_depth(pieces(first), pieces(second))


def jittered_extent(
    entry: CatalogObject,
    placement: ObjectPlacement,
    jitter_xy: float,
    jitter_yaw: float,
    pivot: tuple[float, float] | None = None,
) -> np.ndarray:
    """The x-y box covering an object's footprint at every pose the scene's jitter allows (its centre moved up to
    `jitter_xy` along x and along y, its yaw turned up to `jitter_yaw`, about `pivot`, the centre of the object at
    the bottom of its pile, default its own centre): [[min x, min y], [max x, max y]]."""
    steps = max(1, math.ceil(2 * jitter_yaw / math.radians(JITTER_YAW_STEP_DEG)) + 1)
    points = outline_points(entry)
    pivot_xy = np.asarray(placement.xy if pivot is None else pivot)
    arm = np.asarray(placement.xy) - pivot_xy
    low, high = np.full(2, np.inf), np.full(2, -np.inf)
    for turn in np.linspace(-jitter_yaw, jitter_yaw, steps):
        rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(placement.yaw + float(turn)), placement.tilt)))
        c, s = math.cos(turn), math.sin(turn)
        centre = pivot_xy + np.array([c * arm[0] - s * arm[1], s * arm[0] + c * arm[1]])
        xy = points @ rotation[:2].T + centre
        low, high = np.minimum(low, xy.min(axis=0)), np.maximum(high, xy.max(axis=0))
    return np.stack([low - jitter_xy, high + jitter_xy])


def check_jittered_footprints(
    fields: Fields,
    placements: Sequence[ObjectPlacement],
    catalog: Catalog,
    table_size: tuple[float, float],
    jitter_xy: float,
    jitter_yaw: float,
) -> None:
    """Every object's whole footprint stays on the table at every pose the jitter allows, not only at its nominal
    place (check_layout): an object hanging over the edge in some episodes would tip or fall in those only."""
    table_low = np.asarray(TABLE_CENTER_XY) - np.asarray(table_size) / 2
    table_high = np.asarray(TABLE_CENTER_XY) + np.asarray(table_size) / 2
    by_name = {placement.name: placement for placement in placements}
    for index, placement in enumerate(placements):
        base = placement.name  # the bottom of its pile, or the object on a fixture (fixtures stay still)
        while by_name[base].on is not None and not by_name[by_name[base].on].fixture:
            base = by_name[base].on
        still = placement.fixture
        low, high = jittered_extent(
            catalog[placement.asset],
            placement,
            0.0 if still else jitter_xy,
            0.0 if still else jitter_yaw,
            by_name[base].xy,
        )
        beyond_low, beyond_high = table_low - low, high - table_high
        for axis in range(2):
            over = max(beyond_low[axis], beyond_high[axis])
            if over <= OVERLAP_TOLERANCE:
                continue
            letter = "xy"[axis]
            edge = table_low[axis] if beyond_low[axis] > beyond_high[axis] else table_high[axis]
            raise fields.error(
                f"objects[{index}].xy",
                f"'{placement.name}' reaches {over * 100:.1f} cm past the table's edge at {letter} = {edge:.3f} m at "
                f"some poses the jitter allows ({letter} {low[axis]:.3f}..{high[axis]:.3f} m with jitter.xy "
                f"{jitter_xy:g} m and jitter.yaw_deg {math.degrees(jitter_yaw):g})",
                f"Move it at least {over * 100:.1f} cm further in, make table.size[{axis}] larger, or lower the jitter",
            )


def scene_files(near: Path | None = None) -> dict[str, Path]:
    """Scene files by name: the shipped ones and those of user content folders (robolab_ms.content); with `near` (the
    folder of a task file), also the scene files in that folder and in a sibling scene_builders/ folder, which come
    first (a task's own scene may differ from a known one of the same name)."""
    files = content_files("scenes")
    if near is not None:
        for folder in (near.parent / "scene_builders", near):
            if folder.is_dir() and folder.name != "task_specs":  # a task_specs/ folder holds tasks only
                files.update({path.stem: path for path in sorted(folder.glob("*.yaml"))})
    return files


def scene_names(near: Path | None = None) -> list[str]:
    """The names `scene:` may use in a task file in folder `near` (any task file when None)."""
    return sorted(scene_files(near))


def load_scene(name: str, near: Path | None = None) -> SceneSpec:
    """A scene by name: found next to the task file's folder `near` (same folder, then a sibling scene_builders/),
    else among the shipped scenes and those of user content folders. Read afresh on every call, so edits count."""
    path = scene_files(near).get(name)
    if path is None:
        raise UnknownNameError("scene", name, scene_names(near))
    return read_scene(path)


def load_scene_or_file(scene: str) -> SceneSpec:
    """A scene given by its file (an existing .yaml file) or by its name, as `load_scene` finds it."""
    path = Path(scene)
    return read_scene(path) if path.suffix == ".yaml" and path.is_file() else load_scene(scene)


def resting_height(points: np.ndarray, tilt: Sequence[float]) -> float:
    """The height of the object's origin that puts the lowest of its collision points (object frame, (N, 3)),
    turned by `tilt`, on the table top. A yaw about the world z does not change it."""
    w, x, y, z = tilt
    row_z = np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])  # third row of R
    return -float((points @ row_z).min())
