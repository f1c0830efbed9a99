"""USD to scenes: a USD layout read back into a scene file.

Import (`import_scene`) reads the bodies of a USD layout (this exporter's or one made elsewhere), maps each to a
catalog object (robolab:catalog, a `--map` file, or the name of its referenced asset file), turns each world pose
into the scene file's x, y, yaw and tilt, keeps `rests_on` / `level` (robolab attributes, else inferred from the
heights), writes the scene file and reads it back through the scene loader.
"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.catalog import COLOR_NAMES, Catalog, load_catalog
from robolab_ms.content import Fields, load_yaml
from robolab_ms.errors import RoboLabError, did_you_mean, make_folder
from robolab_ms.scene.spec import (
    DEFAULT_TABLE_COLOR,
    DEFAULT_TABLE_SIZE,
    RESERVED_NAMES,
    SETTLE_CLEARANCE,
    TABLE_CENTER_XY,
    SceneSpec,
    read_scene,
)
from robolab_ms.scene.usd_stage import ANGLE_DECIMALS, check_suffix, pxr_modules, read_attribute, unique_name

LENGTH_DECIMALS = 9  # metres in the imported scene file
STRAIGHT = 1e-9  # a rotation-matrix entry this close to 0 is 0 (a rotation about one axis only)
SUPPORT_NOTE_GAP = 0.01  # m: an imported body further than this from where it would rest gets a note


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


def import_scene(
    usd: Path, out: Path, mapping_file: Path | None = None, catalog: Catalog | None = None
) -> ImportReport:
    """Read the layout of USD file `usd` into the scene file `out` (its name is the file's stem) and read that back
    with the scene loader. Bodies are prims with robolab:catalog, a RigidBodyAPI, a reference or payload, or a
    `--map` entry (`mapping_file`, see read_mapping); RoboLabError naming every prim whose catalog object is
    unknown."""
    pxr = pxr_modules()
    Usd, UsdPhysics = pxr.Usd, pxr.UsdPhysics
    catalog = catalog or load_catalog()
    usd, out = Path(usd), Path(out)
    check_suffix(usd, "FILE")
    if out.suffix != ".yaml":
        raise RoboLabError(f"--out {out}: a scene file ends in .yaml; give e.g. {out.with_suffix('.yaml')}")
    if not usd.is_file():
        raise RoboLabError(f"{usd} is not a file. Name a USD file (.usda, .usd, .usdc)")
    mapping = read_mapping(mapping_file, catalog) if mapping_file else {}
    try:
        stage = Usd.Stage.Open(str(usd))
    except pxr.Tf.ErrorException as error:  # a file USD cannot parse
        raise RoboLabError(
            f"{usd} does not open as a USD stage ({_usd_error_text(error)}); give a USD file that `usdcat` reads"
        ) from None
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
        role = read_attribute(prim, "role")
        if role in ("table", "robot_pedestal") or (role is None and prim.GetName().lower() == "table"):
            table_prim = prim if role == "table" or (role is None and table_prim is None) else table_prim
            iterator.PruneChildren()
            continue
        references = _asset_references(prim)
        keys = [prim.GetPath().pathString, prim.GetName()] + [key for ref in references for key in _reference_keys(ref)]
        mapped, target = _look_up(mapping, keys)
        own = read_attribute(prim, "catalog")
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
        raise RoboLabError(
            f"{usd}: {len(unresolved)} bod{'y' if len(unresolved) == 1 else 'ies'} without a catalog "
            "object: " + "; ".join(unresolved) + ". Map them in a YAML file given with --map "
            "FILE.yaml (asset path, file name or prim name: catalog name, or null to leave the prim "
            "out)"
        )
    if not found:
        raise RoboLabError(
            f"{usd}: no bodies found under {root.GetPath()} (prims with robolab:catalog, a "
            "RigidBodyAPI, a reference or payload). Map prim names to catalog objects with --map "
            "FILE.yaml"
        )
    table_top, table_size, table_centre = _table_geometry(table_prim, convert, notes)
    bodies = []
    taken = set(RESERVED_NAMES)
    for prim, asset in found:
        position, rotation = _world_pose(prim, convert, notes)
        position[2] -= table_top
        body = _Body(prim.GetPath().pathString, _scene_name(prim, taken), asset, position, rotation)
        if read_attribute(prim, "name") is not None:  # a body `robolab scene export` wrote: its support is recorded
            body.rests_on, body.level = read_attribute(prim, "rests_on"), read_attribute(prim, "level")
            body.known_support = True
        mass = prim.GetAttribute("physics:mass").Get() if prim.HasAPI(UsdPhysics.MassAPI) else None
        if mass and abs(mass - catalog[asset].mass) > 0.01 * catalog[asset].mass:
            notes.append(
                f"{body.prim}: mass {mass:g} kg in the USD file, {catalog[asset].mass:g} kg in the catalog "
                f"('{asset}'); the scene uses the catalog's"
            )
        bodies.append(body)
    names = {body.name for body in bodies}
    for body in bodies:
        if body.known_support and body.rests_on is not None and body.rests_on not in names:
            notes.append(f"{body.prim}: rests on '{body.rests_on}', which is not among the bodies; support inferred")
            body.known_support = False
    _infer_supports([body for body in bodies if not body.known_support], bodies, catalog)
    data = _scene_data(out.stem, root, table_prim, table_size, bodies, catalog, usd)
    if abs(table_centre[0] - TABLE_CENTER_XY[0]) > 1e-3 or abs(table_centre[1] - TABLE_CENTER_XY[1]) > 1e-3:
        notes.append(
            f"the table's centre is at x, y = {table_centre[0]:.3f}, {table_centre[1]:.3f} m in the USD "
            f"file; scenes put it at {TABLE_CENTER_XY[0]}, {TABLE_CENTER_XY[1]} (the bodies keep their x, "
            "y)"
        )
    _write_scene_file(data, out, usd)
    from robolab_ms.errors import SpecError

    try:
        spec = read_scene(out, catalog)
    except SpecError as error:
        raise RoboLabError(
            f"the scene file written from {usd} does not pass the scene checks: {error} (fix the "
            "layout in the USD file and import again, or edit the scene file)"
        ) from None
    for body in bodies:
        placement = spec.placement(body.name)
        rest = placement.z - (0.0 if placement.fixture else SETTLE_CLEARANCE)
        if abs(body.position[2] - rest) > SUPPORT_NOTE_GAP and abs(body.position[2] - placement.z) > SUPPORT_NOTE_GAP:
            where = f"on '{placement.on}'" if placement.on else "on the table"
            notes.append(
                f"{body.prim}: its origin is at z = {body.position[2]:.3f} m above the table top in the USD "
                f"file; the scene rests it {where} at z = {rest:.3f} m"
            )
    return ImportReport(usd, out, spec, notes)


def _frame_conversion(stage, notes: list[str]) -> np.ndarray:
    """The 4x4 matrix (column vectors) from the stage's units and up axis to metres and z up (USD reads a stage
    without metersPerUnit as centimetres, one without upAxis as Y up)."""
    pxr = pxr_modules()
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
    pxr = pxr_modules()
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
        raise RoboLabError(
            f"{prim.GetPath()}: its transform mirrors or shears the body; give it a rotation, "
            "translation and uniform scale only"
        )
    if np.abs(scale - 1.0).max() > 1e-6:
        notes.append(
            f"{prim.GetPath()}: scaled by {', '.join(f'{s:g}' for s in scale)} in the USD file; "
            "the catalog object keeps its own size"
        )
    return world[:3, 3].copy(), rotation


def _table_geometry(table_prim, convert: np.ndarray, notes: list[str]) -> tuple[float, tuple[float, float], np.ndarray]:
    """The table top's height, the table's size (x, y) and its centre (x, y) from its world bounds; without a table
    prim the scene defaults (top at z = 0)."""
    pxr = pxr_modules()
    if table_prim is None:
        notes.append(
            f'no table prim (robolab:role "table" or a prim named table): the table top is taken as z = 0 '
            f"and the table is {DEFAULT_TABLE_SIZE[0]} x {DEFAULT_TABLE_SIZE[1]} m"
        )
        return 0.0, DEFAULT_TABLE_SIZE, np.asarray(TABLE_CENTER_XY)
    cache = pxr.UsdGeom.BBoxCache(pxr.Usd.TimeCode.Default(), [pxr.UsdGeom.Tokens.default_])
    box = cache.ComputeWorldBound(table_prim).ComputeAlignedRange()
    low, high = np.array(box.GetMin()), np.array(box.GetMax())
    corners = np.array(
        [[x, y, z, 1.0] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    corners = (convert @ corners.T).T[:, :3]
    low, high = corners.min(axis=0), corners.max(axis=0)
    size = tuple(round(float(v), LENGTH_DECIMALS) for v in (high - low)[:2])
    return float(high[2]), size, (low[:2] + high[:2]) / 2


def _scene_name(prim, taken: set[str]) -> str:
    """A body's scene name: robolab:name, else its prim name made of letters, digits and underscores; unique."""
    name = read_attribute(prim, "name") or prim.GetName()
    name = "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in name) or "body"
    if name in RESERVED_NAMES:
        name = f"{name}_object"
    return unique_name(name, taken)


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


def _scene_data(
    name: str, root, table_prim, table_size: tuple[float, float], bodies: list[_Body], catalog: Catalog, usd: Path
) -> dict:
    """The scene file's content."""
    data: dict[str, Any] = {"name": name}
    description = read_attribute(root, "description") if root.IsValid() else None
    data["description"] = description or f"Imported from {usd.name}."
    table: dict[str, Any] = {"size": list(table_size)}
    material = read_attribute(table_prim, "table_material") if table_prim is not None else None
    if material:
        table["material"] = material
    else:
        rgba = _table_rgba(table_prim)
        colour = next(
            (
                name
                for name, rgb in COLOR_NAMES.items()
                if rgba[3] == 1.0 and max(abs(a - b) for a, b in zip(rgb, rgba)) < 1e-6
            ),
            None,
        )
        if colour:
            table["color"] = colour
        else:
            table["rgba"] = [round(float(c), 6) for c in rgba]
    data["table"] = table
    jitter_xy, jitter_yaw = (None, None)
    if root.IsValid():
        jitter_xy, jitter_yaw = read_attribute(root, "jitter_xy"), read_attribute(root, "jitter_yaw")
    if jitter_xy is not None or jitter_yaw is not None:
        data["jitter"] = {
            key: round(float(value), ANGLE_DECIMALS)
            for key, value in (("xy", jitter_xy), ("yaw_deg", jitter_yaw))
            if value is not None
        }
    background = read_attribute(root, "background") if root.IsValid() else None
    if background:
        data["background"] = background
    items = []
    for body in bodies:
        item: dict[str, Any] = {
            "name": body.name,
            "asset": body.asset,
            "xy": [round(float(v), LENGTH_DECIMALS) + 0.0 for v in body.position[:2]],
        }
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
        return (*COLOR_NAMES[DEFAULT_TABLE_COLOR], 1.0)
    rgba = read_attribute(table_prim, "table_rgba")
    if rgba is not None:
        return tuple(float(c) for c in rgba)
    pxr = pxr_modules()
    if table_prim.IsA(pxr.UsdGeom.Gprim):
        colours = pxr.UsdGeom.Gprim(table_prim).GetDisplayColorAttr().Get()
        if colours:
            return (*(float(c) for c in colours[0]), 1.0)
    return (*COLOR_NAMES[DEFAULT_TABLE_COLOR], 1.0)


def _write_scene_file(data: dict, out: Path, usd: Path) -> None:
    import yaml

    make_folder(out.parent, "--out")
    header = (
        f"# Imported from {usd.name} by `robolab scene import`.\n"
        "# Frame: x away from the robot, y to its left, z up; the table top is z = 0.\n"
    )
    body = yaml.safe_dump(
        {key: data[key] for key in ("name", "description")}, sort_keys=False, width=120, allow_unicode=True
    )
    lines = [
        f"{key}: " + yaml.safe_dump(data[key], default_flow_style=True, sort_keys=False, width=200).strip()
        if isinstance(data[key], dict)
        else yaml.safe_dump({key: data[key]}, allow_unicode=True).strip()
        for key in ("table", "jitter", "background")
        if key in data
    ]
    lines.append("objects:")
    for item in data["objects"]:
        lines.append("  - " + yaml.safe_dump(item, default_flow_style=True, sort_keys=False, width=400).strip())
    out.write_text(header + body + "\n".join(lines) + "\n", encoding="utf-8")
