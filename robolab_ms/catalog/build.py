"""`robolab catalog build`: derive what the catalog needs from the installed asset packages, once.

For every modelled object (source kind `modelled`) it runs the generator and writes the hull file of its convex
pieces (or of coacd's decomposition of its surfaces), its `dimensions` and, for a container, its `interior`.
For every mesh object (a packaged mesh, or a mesh file beside a user catalog: source kind `file`) it reads the
visual mesh, applies the entry's scale and rotation, and writes
  - `transform.translation` (puts the centre of the bottom at the origin) and `dimensions` into the catalog file;
  - the hull file `assets/collision/<name>.obj`: the object's convex collision pieces in the object frame, made
    from the packaged pieces, the mesh's convex hull, or a coacd convex decomposition (the slow one, seconds to
    minutes per mesh; run here and committed, never at environment reset).
Each hull file starts with a fingerprint of its inputs (for a `file` source, the mesh files' contents too; for a
`modelled` source, a hash of what the generator makes, so a changed generator is rebuilt); a second
run skips objects whose inputs did not change, so the command is idempotent and cheap to repeat. coacd's pieces are
also kept in the cache folder under a hash of the mesh and the settings, so the same mesh is decomposed once.
"""

from __future__ import annotations

import glob
import hashlib
import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from robolab_ms.catalog.meshes import load_mesh, package_file, read_hulls, repaired_surface, write_hulls
from robolab_ms.catalog.procedural import generate, procedural_interior
from robolab_ms.catalog.schema import COLLISION_METHODS, MeshTransform, collision_dir, read_catalog
from robolab_ms.content import cache_dir, load_yaml

MAX_HULL_VERTICES = 64  # per convex piece; PhysX allows 255, fewer keeps the hull files small
COACD_PARAMS = {"threshold": 0.05, "max_convex_hull": 24, "preprocess_resolution": 40, "seed": 0}
FINGERPRINT_PREFIX = "# inputs "
KEY_ORDER = [
    "class", "shape", "description", "colors", "rgba", "mass", "friction", "restitution", "container", "interior",
    "fixture", "dimensions", "source", "transform", "collision", "license",
]  # fmt: skip

HEADER = """\
# The robolab_ms object catalog. One entry per object; the schema is in robolab_ms/catalog/schema.py and
# docs/catalog.md. Frame: z up, origin at the centre of the object's bottom, metres and kilograms.
# Procedural objects are generated from their parameters (robolab_ms/catalog/procedural.py) with exact primitive
# collision. Mesh objects come from installed packages; 'robolab catalog build' fills in transform.translation,
# dimensions and the hull files under collision/ (edit the rest by hand, then run it again).
"""


@dataclass
class BuildReport:
    """What a build did."""

    built: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)
    catalog_changed: bool = False


def mesh_files(entry: dict, folder: Path | None = None) -> list[Path]:
    """The visual mesh files of a mesh entry: inside its installed package (source kind `mesh`), or for source kind
    `file` relative to `folder`, the catalog file's folder."""
    source = entry["source"]
    if source["kind"] == "file":
        if folder is None:
            raise ValueError("a `file` source needs the catalog file's folder")
        return [folder / path for path in source["paths"]]
    return [package_file(source["package"], path) for path in source["paths"]]


def file_digest(paths: list[Path]) -> str:
    """A short hash of the contents of files (the mesh files of a `file` source)."""
    digest = hashlib.sha256()
    for path in paths:
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _fingerprint(name: str, entry: dict, folder: Path | None = None, model_digest: str | None = None) -> str:
    source, transform = entry["source"], entry.get("transform", {})
    key = {
        "name": name,
        "source": source,
        "scale": transform.get("scale", 1.0),
        "rotation_deg": transform.get("rotation_deg", [0, 0, 0]),
        "collision": entry["collision"]["method"],
        "coacd": COACD_PARAMS if entry["collision"]["method"] == "coacd" else None,
        "max_vertices": MAX_HULL_VERTICES,
    }
    if source["kind"] == "file":  # a user's file may change under the same name
        key["mesh_digest"] = file_digest(mesh_files(entry, folder))
    if model_digest is not None:  # a generator may change under the same parameters
        key["model_digest"] = model_digest
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]


def _stored_fingerprint(path: Path) -> str | None:
    if not path.is_file():
        return None
    with open(path, encoding="utf-8") as handle:
        for line in handle:
            if line.startswith(FINGERPRINT_PREFIX):
                return line[len(FINGERPRINT_PREFIX) :].strip()
    return None


def _small_hull(points: np.ndarray):
    """The convex hull of a point set with at most MAX_HULL_VERTICES vertices (farthest-point subsampled)."""
    import trimesh

    hull = trimesh.PointCloud(points).convex_hull
    vertices = np.asarray(hull.vertices)
    if len(vertices) > MAX_HULL_VERTICES:
        extremes = {int(i) for axis in range(3) for i in (vertices[:, axis].argmin(), vertices[:, axis].argmax())}
        chosen = list(extremes)
        distance = np.min(np.linalg.norm(vertices[:, None] - vertices[chosen][None], axis=2), axis=1)
        while len(chosen) < MAX_HULL_VERTICES:
            index = int(distance.argmax())
            chosen.append(index)
            distance = np.minimum(distance, np.linalg.norm(vertices - vertices[index], axis=1))
        hull = trimesh.PointCloud(vertices[chosen]).convex_hull
    return hull


def _packaged_pieces(entry: dict, transform: MeshTransform) -> list[np.ndarray]:
    source = entry["source"]
    folder = package_file(source["package"], source["paths"][0]).parent
    files = sorted(glob.glob(str(folder / source["collision_pieces"])))
    if not files:
        raise FileNotFoundError(f"no packaged collision pieces match {folder / source['collision_pieces']}")
    pieces = []
    for file in files:
        if file.endswith(".stl"):
            pieces.append(np.asarray(load_mesh(file).vertices))
        else:
            pieces.extend(read_hulls(file))  # OBJ files with one group per convex piece
    return [transform.apply(piece, translate=False) for piece in pieces]


def coacd_cache_file(vertices: np.ndarray, faces: np.ndarray) -> Path:
    """Where coacd's pieces of this mesh (vertices in the object's orientation and scale) are kept: the cache folder,
    under a hash of the vertices, the triangles, coacd's settings and its version."""
    import coacd

    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(vertices, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    digest.update(json.dumps([COACD_PARAMS, getattr(coacd, "__version__", "")], sort_keys=True).encode())
    return cache_dir() / "coacd" / f"{digest.hexdigest()[:32]}.npz"


def coacd_pieces(vertices: np.ndarray, faces: np.ndarray) -> tuple[list[np.ndarray], bool]:
    """coacd's convex pieces (vertex arrays) of a mesh, and whether they came from the cache (coacd_cache_file)."""
    cached = coacd_cache_file(vertices, faces)
    if cached.is_file():
        try:
            with np.load(cached) as stored:
                return [stored[f"piece{index}"] for index in range(len(stored.files))], True
        except (OSError, ValueError, KeyError):
            pass  # a damaged cache file: decompose again and replace it
    import coacd

    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(vertices, faces), **COACD_PARAMS)
    pieces = [np.asarray(part_vertices, dtype=np.float64) for part_vertices, _ in parts]
    cached.parent.mkdir(parents=True, exist_ok=True)
    partial = cached.with_suffix(f".{os.getpid()}.partial.npz")
    np.savez_compressed(partial, **{f"piece{index}": piece for index, piece in enumerate(pieces)})
    os.replace(partial, cached)
    return pieces, False


def build_object(
    name: str, entry: dict, out_dir: Path, force: bool = False, folder: Path | None = None, notes: dict | None = None
) -> bool:
    """Fill in one mesh entry's translation and dimensions and write its hull file; False when already current.
    `folder` is the catalog file's folder, where the paths of a `file` source start; `notes`, when given, receives
    `coacd_cached` (whether coacd's pieces came from the cache) for the coacd method."""
    fingerprint = _fingerprint(name, entry, folder)
    hull_path = out_dir / entry["collision"].get("file", f"{name}.obj")
    if not force and _stored_fingerprint(hull_path) == fingerprint and "dimensions" in entry:
        return False
    spec = entry.setdefault("transform", {})
    scale = spec.get("scale", 1.0)
    transform = MeshTransform(
        scale=(float(scale),) * 3 if isinstance(scale, (int, float)) else tuple(float(s) for s in scale),
        rotation_deg=tuple(float(a) for a in spec.get("rotation_deg", [0, 0, 0])),
    )
    meshes = [load_mesh(str(path)) for path in mesh_files(entry, folder)]
    vertices = np.concatenate([transform.apply(np.asarray(mesh.vertices), translate=False) for mesh in meshes])
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    translation = np.array([-(low[0] + high[0]) / 2, -(low[1] + high[1]) / 2, -low[2]])
    method = entry["collision"]["method"]
    if method == "packaged_pieces":
        pieces = _packaged_pieces(entry, transform)
    elif method == "convex_hull":
        pieces = [vertices]
    elif method == "coacd":
        offsets = np.cumsum([0] + [len(mesh.vertices) for mesh in meshes[:-1]])
        faces = np.concatenate([np.asarray(mesh.faces) + offset for mesh, offset in zip(meshes, offsets)])
        surface, _ = repaired_surface(vertices, faces)  # one closed surface where trimesh can make it one
        pieces, cached = coacd_pieces(np.asarray(surface.vertices), np.asarray(surface.faces))
        if notes is not None:
            notes["coacd_cached"] = cached
    else:
        raise ValueError(f"{name}: collision method {method!r} is not one of {', '.join(COLLISION_METHODS)}")
    _write_hull_file(hull_path, [piece + translation for piece in pieces], fingerprint)
    spec["translation"] = [round(float(t), 5) for t in translation]
    entry["dimensions"] = [round(float(d), 4) for d in high - low]
    return True


def _write_hull_file(path: Path, pieces: list[np.ndarray], fingerprint: str) -> None:
    """Write convex pieces (vertex arrays, object frame) as a hull file that starts with its inputs' fingerprint."""
    write_hulls(path, [_small_hull(piece) for piece in pieces if len(piece) >= 4])
    text = path.read_text(encoding="utf-8")
    path.write_text(f"{FINGERPRINT_PREFIX}{fingerprint}\n{text}", encoding="utf-8")


def build_modelled(
    name: str, entry: dict, out_dir: Path, catalog_file: Path, force: bool = False, notes: dict | None = None
) -> bool:
    """Write a modelled entry's hull file and fill in its dimensions (and a container's interior); False when
    already current. `notes`, when given, receives `coacd_cached` for the coacd method."""
    from robolab_ms.catalog.schema import MODELLED_COLLISION_METHODS, modelled_model
    from robolab_ms.errors import SpecError

    model = modelled_model(name, entry, catalog_file)
    method = entry.get("collision", {}).get("method") if isinstance(entry.get("collision"), dict) else None
    if method not in MODELLED_COLLISION_METHODS:
        raise SpecError(
            catalog_file,
            f"objects.{name}.collision.method",
            f"must be one of {', '.join(MODELLED_COLLISION_METHODS)} for a modelled object, got {method!r}",
            "Write collision: {method: modelled_pieces}",
        )
    fingerprint = _fingerprint(name, entry, model_digest=model.digest())
    hull_path = out_dir / entry["collision"].get("file", f"{name}.obj")
    if not force and _stored_fingerprint(hull_path) == fingerprint and "dimensions" in entry:
        return False
    if method == "coacd":
        solid = model.solid()
        pieces, cached = coacd_pieces(np.asarray(solid.vertices), np.asarray(solid.faces))
        if notes is not None:
            notes["coacd_cached"] = cached
    else:
        pieces = list(model.pieces)
    _write_hull_file(hull_path, pieces, fingerprint)
    low, high = model.bounds
    entry["dimensions"] = [round(float(d), 4) for d in high - low]
    if entry.get("container") and "interior" not in entry and model.interior is not None:
        entry["interior"] = [round(float(d), 4) for d in model.interior]
    return True


def _describe_procedural(entry: dict) -> None:
    """Record a procedural object's exact dimensions and, for a container, its interior (from its parameters)."""
    source = entry["source"]
    parts = generate(source["generator"], source.get("params", {}))
    lows = [np.asarray(part.position) - part.half_extent() for part in parts]
    highs = [np.asarray(part.position) + part.half_extent() for part in parts]
    size = np.max(highs, axis=0) - np.min(lows, axis=0)
    entry["dimensions"] = [round(float(d), 4) for d in size]
    if entry.get("container") and "interior" not in entry:
        interior = procedural_interior(source["generator"], source.get("params", {}))
        if interior is not None:
            entry["interior"] = [round(float(d), 4) for d in interior]


def dump_catalog(data: dict, header: str = HEADER) -> str:
    """The catalog as YAML text: a header, then one block per object with short lists and mappings inline."""
    lines = [header.rstrip(), f"version: {data.get('version', 1)}", "objects:"]
    for name, entry in data["objects"].items():
        lines.append(f"  {name}:")
        ordered = sorted(entry, key=lambda key: KEY_ORDER.index(key) if key in KEY_ORDER else len(KEY_ORDER))
        for key in ordered:
            value = entry[key]
            if isinstance(value, (dict, list)):
                text = yaml.safe_dump(value, default_flow_style=True, width=10_000, sort_keys=False).strip()
            else:
                text = yaml.safe_dump(value, default_flow_style=True, width=10_000).strip()
                if text.endswith("\n..."):
                    text = text[: -len("\n...")]
                text = text.removesuffix("...").strip()
            lines.append(f"    {key}: {text}")
    return "\n".join(lines) + "\n"


def build_catalog(
    catalog_file: Path,
    names: list[str] | None = None,
    force: bool = False,
    progress: Callable[[str], None] = print,
) -> BuildReport:
    """Build every modelled and mesh object of a catalog file (or only `names`), then check and rewrite the file
    (keeping the comment lines it starts with)."""
    from robolab_ms.errors import SpecError, UnknownNameError

    data = load_yaml(catalog_file)
    objects = data.get("objects") if isinstance(data, dict) else None
    if not isinstance(objects, dict) or not all(isinstance(entry, dict) for entry in objects.values()):
        raise SpecError(
            catalog_file,
            "objects",
            f"must be a mapping of object names to entries, got "
            f"{type(objects).__name__ if objects is not None else 'nothing'}",
            "Give a catalog file such as assets/catalog.yaml",
        )
    for name in names or []:
        if name not in objects:
            raise UnknownNameError("catalog object", name, objects)
    out_dir = collision_dir(catalog_file)
    report = BuildReport()
    header = file_header(catalog_file) or HEADER
    before = dump_catalog(data, header)
    for entry in objects.values():
        if entry.get("source", {}).get("kind") == "procedural":
            _describe_procedural(entry)
    built_kinds = ("modelled", "mesh", "file")
    mesh_names = [name for name, entry in objects.items() if entry.get("source", {}).get("kind") in built_kinds]
    selected = [name for name in mesh_names if names is None or name in names]
    for index, name in enumerate(selected, 1):
        start = time.perf_counter()
        if objects[name]["source"]["kind"] == "modelled":
            changed = build_modelled(name, objects[name], out_dir, catalog_file, force)
        else:
            changed = build_object(name, objects[name], out_dir, force, folder=catalog_file.parent)
        seconds = time.perf_counter() - start
        (report.built if changed else report.skipped).append(name)
        report.seconds[name] = seconds
        state = f"built in {seconds:.1f} s" if changed else "up to date"
        progress(f"[{index}/{len(selected)}] {name}: {state}")
    after = dump_catalog(data, header)
    if after != before or catalog_file.read_text(encoding="utf-8") != after:
        catalog_file.write_text(after, encoding="utf-8")
        report.catalog_changed = True
    read_catalog(catalog_file)  # the result must pass the schema
    return report


def file_header(file: Path) -> str:
    """The comment lines a catalog file starts with ('' when none)."""
    lines = []
    for line in file.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        lines.append(line)
    return "\n".join(lines) + "\n" if lines else ""
