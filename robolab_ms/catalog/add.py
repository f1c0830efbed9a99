"""`robolab catalog add`: a mesh file of your own into the catalog of a user content folder.

The mesh is read and surveyed in the object frame (after `--scale` and `--up`): it must hold triangles, have a
thickness, be a table-top size and be a closed surface once trimesh's repairs ran. It is then copied into
DIR/assets/meshes/NAME/ (an OBJ with its material library and textures), its entry (source kind `file`, with
`source.origin` and `license` marked for the user to fill in) goes into DIR/assets/catalog.yaml, and
`robolab_ms.catalog.build` makes its transform, dimensions and coacd collision pieces (cached by the mesh's
content). The entry must then pass the schema and the SAPIEN check of `robolab catalog check`; otherwise
everything written is put back as it was. Last, the user catalog's contact sheet is rendered.
"""

from __future__ import annotations

import re
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robolab_ms.catalog.meshes import repaired_surface
from robolab_ms.catalog.schema import (
    CATALOG_VERSION,
    COLOR_NAMES,
    MAX_MASS,
    OBJECT_CLASSES,
    SHAPE_KINDS,
    MeshTransform,
    collision_dir,
    load_catalog,
    read_catalog,
)
from robolab_ms.content import CONTENT_ENV, USER_CATALOG, load_yaml, user_content_roots
from robolab_ms.errors import RoboLabError, did_you_mean, make_folder

MESH_SUFFIXES = (".obj", ".glb", ".stl")
# Rotation (extrinsic x, y, z, degrees) that turns each up axis of a file into +z.
UP_ROTATIONS = {
    "z": [0.0, 0.0, 0.0], "-z": [180.0, 0.0, 0.0], "y": [90.0, 0.0, 0.0], "-y": [-90.0, 0.0, 0.0],
    "x": [0.0, -90.0, 0.0], "-x": [0.0, 90.0, 0.0],
}  # fmt: skip
DEFAULT_UP = {".glb": "y", ".obj": "z", ".stl": "z"}  # glTF is y-up by its specification
MIN_SIZE = 0.005  # m: the largest extent of a table-top object is at least this ...
MAX_SIZE = 1.5  # m: ... and at most this
MIN_THICKNESS = 1e-3  # the smallest extent, as a share of the largest: below it the mesh is flat
MIN_VOLUME = 1e-9  # m^3 (1 mm^3) that a closed mesh must enclose
UNIT_SCALES = {"millimetres": 0.001, "centimetres": 0.01, "inches": 0.0254, "decimetres": 0.1}
# Mass per collision volume (kg/m^3) when --mass is not given: the median of the shipped catalog's objects of each
# class (mass over the volume of the convex collision pieces, as `robolab catalog check` measures density).
CLASS_DENSITY = {
    "fruit": 850.0, "vegetable": 810.0, "food": 640.0, "container": 1050.0, "tableware": 650.0, "utensil": 1180.0,
    "tool": 1440.0, "toy": 370.0, "block": 620.0, "electronics": 660.0, "bottle": 780.0, "can": 1020.0,
    "box": 860.0, "furniture": 630.0, "other": 550.0,
}  # fmt: skip
DEFAULT_FRICTION = (0.8, 0.6)  # static, dynamic: as most shipped objects
TO_FILL = "TO FILL IN"  # marks the fields only the user can give (where the mesh comes from, its licence)
DEFAULT_CONTENT = "my_content"  # where objects go without --content or ROBOLAB_CONTENT
SHEET_FILE = "contact_sheet.png"  # beside the user catalog
USER_HEADER = """\
# Catalog objects of this content folder, written by 'robolab catalog add' (schema: docs/catalog.md). Each mesh
# lies under meshes/, its convex collision pieces under collision/. Fill in every field marked TO FILL IN (where the
# mesh comes from and its licence). After editing by hand run 'robolab catalog build --catalog THIS_FILE'.
"""


class MeshError(RoboLabError):
    """A mesh file that cannot become a catalog object: names the file, the problem and a fix."""

    def __init__(self, path: Path, problem: str, fix: str) -> None:
        super().__init__(f"{path}: {problem}. {fix}")


@dataclass
class MeshSurvey:
    """What reading a mesh file found, in the object frame (scaled, rotated up; metres)."""

    path: Path
    dimensions: np.ndarray
    volume: float | None  # enclosed volume (m^3); None for an open surface let through with allow_open
    faces: int
    closed: bool
    repairs: list[str] = field(default_factory=list)
    textured: bool = False
    colour: str | None = None  # the named colour nearest the mesh's own, when it has one
    companions: list[Path] = field(default_factory=list)  # files an OBJ refers to (material libraries, textures)


@dataclass
class AddResult:
    """What `add_object` wrote and measured."""

    name: str
    catalog_file: Path
    mesh_files: list[Path]
    collision_file: Path
    sheet: Path | None
    survey: MeshSurvey
    dimensions: list[float]
    mass: float
    mass_from_density: bool
    pieces: int
    coacd_cached: bool
    seconds: dict[str, float]
    measured: dict[str, float]
    to_fill: list[str]


def content_target(folder: str | Path | None = None) -> Path:
    """The user content folder `catalog add` writes to: `folder`, else the first of ROBOLAB_CONTENT, else
    ./my_content (created when missing)."""
    if folder is not None:
        return Path(folder).expanduser().resolve()
    roots = user_content_roots()
    return roots[0] if roots else Path(DEFAULT_CONTENT).resolve()


def survey_mesh(path: str | Path, scale: float = 1.0, up: str | None = None, allow_open: bool = False) -> MeshSurvey:
    """Read a mesh file and check it can be a table-top object; MeshError (naming the file and a fix) otherwise."""
    import trimesh

    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise MeshError(path, "does not exist" if not path.exists() else "is not a file", "Check the path")
    if suffix not in MESH_SUFFIXES:
        raise MeshError(
            path,
            f"has the suffix '{path.suffix}', not one of {', '.join(MESH_SUFFIXES)}",
            "Export it as OBJ, GLB or STL (Blender: File > Export)",
        )
    if path.stat().st_size == 0:
        raise MeshError(path, "is empty (0 bytes)", "Export the mesh again from your modelling tool")
    if not (0 < scale < 1e6):
        raise MeshError(path, f"--scale {scale:g} is not a positive factor", "Give the metres per unit of the file")
    up = up or DEFAULT_UP[suffix]
    if up not in UP_ROTATIONS:
        raise MeshError(path, f"--up '{up}' is not an axis", f"Use one of {', '.join(UP_ROTATIONS)}")
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False)
    except Exception as error:  # noqa: BLE001 - any parser failure means the file cannot be used
        raise MeshError(
            path,
            f"cannot be read as a {suffix[1:].upper()} mesh ({type(error).__name__}: {error})",
            "Check that the file is complete; open it in a mesh tool (Blender, MeshLab) and export it again",
        ) from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(
            path,
            f"holds no triangles (it is not a {suffix[1:].upper()} mesh trimesh can read, or has vertices only)",
            "Export the object's surface as a triangle mesh",
        )
    transform = MeshTransform(scale=(scale,) * 3, rotation_deg=tuple(UP_ROTATIONS[up]))
    vertices = transform.apply(np.asarray(loaded.vertices, dtype=np.float64), translate=False)
    if not np.isfinite(vertices).all():
        raise MeshError(
            path, "has vertices that are not finite numbers (NaN or infinity)", "Repair or export the mesh again"
        )
    survey = MeshSurvey(path, np.zeros(3), None, len(loaded.faces), False)
    _check_shape(survey, np.ptp(vertices[np.unique(np.asarray(loaded.faces))], axis=0), scale)
    geometry, survey.repairs = repaired_surface(vertices, np.asarray(loaded.faces))  # as coacd will get it
    if geometry.is_watertight:
        survey.closed = True
        survey.volume = abs(float(geometry.volume))
        if survey.volume < MIN_VOLUME:
            raise MeshError(
                path,
                f"encloses no volume ({survey.volume:.2e} m^3): it is degenerate",
                "A catalog object must be a solid; export the object's closed outer surface",
            )
    elif not allow_open:
        raise MeshError(
            path,
            f"is not a closed surface, and trimesh's repairs did not close it: {_edge_report(geometry)}",
            "Close it in a mesh tool (Blender: Select > All by Trait > "
            "Non Manifold, then fill the holes; MeshLab: Close Holes), or pass --allow-open to let "
            "coacd's preprocessing close it",
        )
    else:
        survey.repairs.append(f"left open (--allow-open): {_edge_report(geometry)}")
    survey.textured, survey.colour = _appearance(loaded, path)
    if suffix == ".glb" and not survey.textured:  # parts with their own textures are merged without them
        parts = trimesh.load(str(path))
        survey.textured = any(_image_of(part.visual) is not None for part in getattr(parts, "geometry", {}).values())
    if suffix == ".obj":
        survey.companions = obj_companions(path)
        survey.textured = any(companion.suffix.lower() != ".mtl" for companion in survey.companions)
    return survey


def _check_shape(survey: MeshSurvey, extents: np.ndarray, scale: float) -> None:
    """The mesh (`extents` of its triangles) has a thickness and a table-top size (else MeshError, with the
    --scale that would fit)."""
    survey.dimensions = extents
    largest = float(extents.max())
    if largest <= 0 or float(extents.min()) < MIN_THICKNESS * largest:
        axis = "xyz"[int(extents.argmin())]
        raise MeshError(
            survey.path,
            f"is flat: it has no thickness along {axis} (extents {_metres(extents)}), so it encloses no volume",
            "A catalog object must be a solid: give the surface a thickness "
            "(Blender: Solidify modifier) and export it again",
        )
    if MIN_SIZE <= largest <= MAX_SIZE:
        return
    too = "large" if largest > MAX_SIZE else "small"
    fits = [(unit, factor) for unit, factor in UNIT_SCALES.items() if too == "large" and 0.01 <= largest * factor <= 1]
    if fits:
        fix = "If the file is in " + ", or in ".join(f"{unit} pass --scale {scale * factor:g}" for unit, factor in fits)
    else:
        fix = (
            f"Pass --scale with the metres per unit of the file, e.g. --scale {scale * 0.1 / largest:.3g} for an "
            "object 10 cm across"
        )
    raise MeshError(
        survey.path,
        f"is too {too} for a table-top object: {largest:g} m across at --scale {scale:g} "
        f"(extents {_metres(extents)}; objects are {MIN_SIZE * 1000:g} mm to {MAX_SIZE:g} m)",
        fix,
    )


def _edge_report(geometry) -> str:
    """How many edges border a hole and how many are shared by more than two triangles."""
    edges = np.sort(np.asarray(geometry.edges), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return (
        f"{int((counts == 1).sum())} edges border a hole and {int((counts > 2).sum())} are shared by more than "
        "two triangles"
    )


def _metres(extents: np.ndarray) -> str:
    return " x ".join(f"{value:.4g}" for value in extents) + " m"


def _appearance(loaded, path: Path) -> tuple[bool, str | None]:
    """Whether the mesh carries an image texture, and the named colour nearest its own colour (None when it has only
    trimesh's default grey)."""
    visual = loaded.visual
    textured = False
    rgba = None
    if getattr(visual, "kind", None) == "texture":
        material = getattr(visual, "material", None)
        textured = _image_of(visual) is not None and path.suffix.lower() == ".glb"  # an OBJ's: its companions
        try:
            rgba = np.asarray(material.main_color, dtype=float)
        except (AttributeError, ValueError, TypeError):
            rgba = None
    elif getattr(visual, "kind", None) in ("face", "vertex"):
        rgba = np.asarray(visual.main_color, dtype=float)
    if rgba is None or rgba.shape[-1] < 3 or np.allclose(rgba[:3], 102, atol=1):  # trimesh's default grey
        return textured, None
    rgb = rgba[:3] / 255.0
    return textured, min(COLOR_NAMES, key=lambda name: float(np.sum((np.asarray(COLOR_NAMES[name]) - rgb) ** 2)))


def _image_of(visual):
    """The image texture of a trimesh visual, or None."""
    material = getattr(visual, "material", None)
    image = getattr(material, "baseColorTexture", None)
    return image if image is not None else getattr(material, "image", None)


def obj_companions(path: Path) -> list[Path]:
    """The files an OBJ needs beside it: its material libraries (`mtllib`) and the textures they name, when they
    exist inside the OBJ's folder."""
    folder = path.parent.resolve()
    found: list[Path] = []

    def keep(candidate: Path) -> None:
        candidate = candidate.resolve()
        if candidate.is_file() and candidate.is_relative_to(folder) and candidate not in found:
            found.append(candidate)

    text = path.read_text(encoding="utf-8", errors="replace")
    for match in re.finditer(r"^\s*mtllib\s+(.+?)\s*$", text, flags=re.MULTILINE):
        library = folder / match.group(1)
        keep(library)
        if not library.is_file():
            continue
        for line in library.read_text(encoding="utf-8", errors="replace").splitlines():
            words = line.split()
            if words and (words[0].lower().startswith("map_") or words[0].lower() in ("bump", "disp", "norm")):
                keep(library.parent / words[-1])
    return found


def _check_name(name: str, catalog_file: Path, replace: bool) -> None:
    """`name` is a valid object name used by no catalog but (with `replace`) the target one."""
    if not name or not name.isascii() or not name.replace("_", "").isalnum():
        raise RoboLabError(f"--name '{name}' is not a catalog name: use letters, digits and underscores, e.g. red_vase")
    own = read_catalog(catalog_file).objects if catalog_file.is_file() else {}
    if name in own:
        if not replace:
            raise RoboLabError(
                f"catalog object '{name}' is already in {catalog_file}. Pass --replace to replace "
                "it, or choose another --name"
            )
        return
    known = load_catalog()
    if name in known:
        where = known[name].folder or known.file
        raise RoboLabError(
            f"catalog object '{name}' already exists (in {where}). Choose another --name; names are "
            "unique across the shipped catalog and every content folder"
        )


def _default_mass(object_class: str, hulls: tuple[np.ndarray, ...]) -> float:
    from robolab_ms.catalog.meshes import hull_volume

    volume = sum(hull_volume(hull) for hull in hulls)
    return float(f"{CLASS_DENSITY[object_class] * volume:.3g}")


class _Undo:
    """Files as they were before `add_object` wrote: restored when it fails."""

    def __init__(self) -> None:
        self.saved: list[tuple[Path, bytes | None]] = []
        self.folders: list[Path] = []

    def file(self, path: Path) -> None:
        self.saved.append((path, path.read_bytes() if path.is_file() else None))

    def folder(self, path: Path) -> None:
        """A folder that is replaced as a whole (moved aside until `commit`)."""
        if path.exists():
            aside = path.with_name(path.name + ".replaced")
            shutil.rmtree(aside, ignore_errors=True)
            path.rename(aside)
        self.folders.append(path)

    def restore(self) -> None:
        for path, content in reversed(self.saved):
            if content is None:
                path.unlink(missing_ok=True)
            else:
                path.write_bytes(content)
        for path in self.folders:
            shutil.rmtree(path, ignore_errors=True)
            aside = path.with_name(path.name + ".replaced")
            if aside.exists():
                aside.rename(path)

    def commit(self) -> None:
        for path in self.folders:
            shutil.rmtree(path.with_name(path.name + ".replaced"), ignore_errors=True)


def add_object(
    mesh: str | Path,
    name: str,
    object_class: str,
    *,
    content: str | Path | None = None,
    mass: float | None = None,
    scale: float = 1.0,
    up: str | None = None,
    description: str | None = None,
    colors: list[str] | None = None,
    friction: tuple[float, float] = DEFAULT_FRICTION,
    origin: str | None = None,
    license: str | None = None,
    allow_open: bool = False,
    replace: bool = False,
    sheet: bool = True,
    shape: str = "modelled",
    progress: Callable[[str], None] = print,
) -> AddResult:
    """Add a mesh file as catalog object `name` to a user content folder (see the module docstring)."""
    from robolab_ms.catalog import build as building
    from robolab_ms.catalog.check import check_object, contact_sheet
    from robolab_ms.catalog.meshes import read_hulls

    if object_class not in OBJECT_CLASSES:
        raise RoboLabError(
            f"--class '{object_class}' is not an object class ({', '.join(OBJECT_CLASSES)}). "
            f"{did_you_mean(object_class, OBJECT_CLASSES)}"
        )
    if shape not in SHAPE_KINDS:
        raise RoboLabError(
            f"--shape '{shape}' is not a shape kind ({', '.join(SHAPE_KINDS)}). {did_you_mean(shape, SHAPE_KINDS)}"
        )
    for colour in colors or []:
        if colour not in COLOR_NAMES:
            raise RoboLabError(f"--colors: '{colour}' is not a colour name. {did_you_mean(colour, COLOR_NAMES)}")
    if mass is not None and not 0 < mass <= MAX_MASS:
        raise RoboLabError(f"--mass {mass:g} is not between 0 and {MAX_MASS:g} kg")
    static, dynamic = friction
    if not 0 < dynamic <= static <= 5:
        raise RoboLabError(f"--friction {static:g} {dynamic:g}: give static then dynamic, 0 < dynamic <= static <= 5")
    root = content_target(content)
    catalog_file = root / USER_CATALOG
    _check_name(name, catalog_file, replace)
    seconds: dict[str, float] = {}
    start = time.perf_counter()
    survey = survey_mesh(mesh, scale, up, allow_open)
    seconds["survey"] = time.perf_counter() - start
    progress(
        f"{survey.path.name}: {survey.faces} triangles, {_metres(survey.dimensions)}"
        + (f"; repaired: {', '.join(survey.repairs)}" if survey.repairs else "")
    )

    folder = catalog_file.parent
    mesh_folder = folder / "meshes" / name
    hull_file = collision_dir(catalog_file) / f"{name}.obj"
    source = survey.path.resolve()
    suffix = source.suffix.lower()
    staging = mesh_folder.with_name(f".{name}.new")  # copied first: the source may lie in the folder it replaces
    shutil.rmtree(staging, ignore_errors=True)
    make_folder(staging.parent, "--content")
    staging.mkdir()
    for file in [source, *survey.companions]:
        target = staging / file.relative_to(source.parent)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(file, target)
    copies = [mesh_folder / file.relative_to(source.parent) for file in [source, *survey.companions]]
    undo = _Undo()
    undo.file(catalog_file)
    undo.file(hull_file)
    undo.folder(mesh_folder)
    try:
        staging.rename(mesh_folder)
        entry = {
            "class": object_class,
            "shape": shape,
            "description": description or f"A {name.replace('_', ' ')} (added from {source.name}).",
            "colors": list(colors or [survey.colour or "grey"]),
            "mass": mass or 1.0,  # replaced below by the class density times the collision volume
            "friction": {"static": static, "dynamic": dynamic},
            "source": {
                "kind": "file",
                "paths": [copies[0].relative_to(folder).as_posix()],
                "textured": survey.textured,
                "origin": origin
                or f"{TO_FILL}: where the mesh comes from (web address or author); added from {source.name}",
            },
            "transform": {"scale": scale, "rotation_deg": list(UP_ROTATIONS[up or DEFAULT_UP[suffix]])},
            "collision": {"method": "coacd"},
            "license": license or f"{TO_FILL}: the mesh's licence as its author gives it (e.g. CC-BY-4.0)",
        }
        start = time.perf_counter()
        _forget_files()  # a replaced object's files keep their names
        notes: dict = {}
        building.build_object(name, entry, hull_file.parent, force=True, folder=folder, notes=notes)
        seconds["coacd"] = time.perf_counter() - start
        hulls = read_hulls(str(hull_file))
        if mass is None:
            entry["mass"] = _default_mass(object_class, hulls)
            if not 0 < entry["mass"] <= MAX_MASS:
                raise RoboLabError(
                    f"{survey.path}: the {object_class} density {CLASS_DENSITY[object_class]:g} "
                    f"kg/m^3 gives {entry['mass']:g} kg, not between 0 and {MAX_MASS:g} kg. Give "
                    "--mass"
                )
        data = load_yaml(catalog_file) if catalog_file.is_file() else {"version": CATALOG_VERSION, "objects": {}}
        data["objects"][name] = entry
        header = building.file_header(catalog_file) if catalog_file.is_file() else USER_HEADER
        catalog_file.write_text(building.dump_catalog(data, header or USER_HEADER), encoding="utf-8")
        added = read_catalog(catalog_file)
        _forget_files()
        start = time.perf_counter()
        result = check_object(added[name])
        seconds["check"] = time.perf_counter() - start
        if not result.passed:
            raise RoboLabError(
                f"{survey.path}: as catalog object '{name}' it fails the SAPIEN check: "
                f"{'; '.join(result.problems)}. {_check_fix(result.problems)}"
            )
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        undo.restore()
        raise
    undo.commit()
    sheet_file = None
    if sheet:
        start = time.perf_counter()
        sheet_file = contact_sheet(
            added, folder / SHEET_FILE, tile=160, columns=min(6, len(added)), progress=lambda line: None
        )
        seconds["sheet"] = time.perf_counter() - start
    given = {"source.origin": entry["source"]["origin"], "license": entry["license"]}
    to_fill = [f"objects.{name}.{key}" for key, value in given.items() if value.startswith(TO_FILL)]
    return AddResult(
        name,
        catalog_file,
        copies,
        hull_file,
        sheet_file,
        survey,
        entry["dimensions"],
        entry["mass"],
        mass is None,
        len(hulls),
        notes["coacd_cached"],
        seconds,
        result.measured,
        to_fill,
    )


def _forget_files() -> None:
    """Drop what this process cached by file name (parsed meshes, hull files, SAPIEN's cooked collision shapes)."""
    import sapien

    from robolab_ms.catalog.appearance import projected_mesh
    from robolab_ms.catalog.meshes import load_mesh, read_hulls

    for cache in (load_mesh, read_hulls, projected_mesh):
        cache.cache_clear()
    sapien.physx.clear_cache()


def _check_fix(problems: list[str]) -> str:
    """What to change when the SAPIEN check fails."""
    text = " ".join(problems)
    if "upright" in text or "stay put" in text:
        return "Check which way is up (--up x, y, z, -x, -y or -z) so that it stands on its base"
    if "density" in text:
        return "Give --mass in kg"
    if "SAPIEN mass" in text:
        return (
            "PhysX cooked the convex pieces with another volume, as it does for very thin pieces: close the "
            "surface or give its walls a thickness, and export it again"
        )
    return "Look at the mesh in a mesh tool; the problems above say what SAPIEN measured"


def describe(result: AddResult) -> str:
    """The report `robolab catalog add` prints."""
    size = " x ".join(f"{value * 100:.1f}" for value in result.dimensions)
    mass = f"{result.mass:g} kg"
    if result.mass_from_density:
        mass += " (class density x collision volume; --mass sets it)"
    coacd = "cached" if result.coacd_cached else f"{result.seconds['coacd']:.1f} s"
    lines = [
        f"added '{result.name}' to {result.catalog_file}",
        f"  size {size} cm, {mass}, {result.pieces} convex collision piece(s) (coacd: {coacd})",
        f"  SAPIEN check passed: drift {result.measured.get('drift', 0) * 100:.2f} cm, tilt "
        f"{result.measured.get('tilt_deg', 0):.1f} deg, size error {result.measured.get('size_error', 0):.1%}",
        f"  mesh: {', '.join(str(path) for path in result.mesh_files)}",
        f"  collision: {result.collision_file}",
    ]
    if result.sheet is not None:
        lines.append(f"  contact sheet: {result.sheet}")
    lines.append("  seconds: " + ", ".join(f"{step} {value:.1f}" for step, value in result.seconds.items()))
    if result.to_fill:
        lines.append(f"  fill in {' and '.join(result.to_fill)} (marked '{TO_FILL}') in {result.catalog_file}")
    root = result.catalog_file.parents[1]
    lines.append(f"  use it in scenes as `asset: {result.name}` with --content {root} (or {CONTENT_ENV}={root})")
    return "\n".join(lines)
