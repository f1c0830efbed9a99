"""Resting one scene object on another: how high an object's origin must be so that the object, turned as the
scene says and lowered straight down at its x, y, just touches its support (a cube on a cube, a can on a box, a
keyboard leaning over a bin's rim onto its floor).

The collision geometry of both objects is a set of convex pieces (a procedural object's primitives, a mesh object's
hulls). Over a grid of vertical lines through the place where their outlines meet, the lowest point of the turned
object and the highest point of the placed support are found exactly for each line from the pieces' face planes;
the object's origin goes where the largest "support top minus object bottom" puts it. The grid step bounds the
error on a sloped surface to step / 2 times the slope (a fraction of a millimetre).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from robolab_ms.catalog import CatalogObject

GRID_STEP = 0.002  # m between the vertical lines
FLAT = 1e-9  # a face whose normal has a smaller z is vertical

Facets = tuple[np.ndarray, np.ndarray]  # (F, 3) outward unit normals, (F,) offsets: inside where n . p + d <= 0

_PIECES: dict[int, tuple[CatalogObject, tuple[np.ndarray, ...]]] = {}


def convex_pieces(entry: CatalogObject) -> tuple[np.ndarray, ...]:
    """The vertices of each convex collision piece of a catalog object, object frame: a procedural object's
    primitives (boxes exact, round shapes as their sample points), a mesh object's hulls."""
    cached = _PIECES.get(id(entry))
    if cached is None or cached[0] is not entry:
        pieces = tuple(part.surface_points() for part in entry.parts) if entry.parts else tuple(entry.hulls)
        cached = (entry, pieces)
        _PIECES[id(entry)] = cached
    return cached[1]


def _facets(points: np.ndarray) -> Facets | None:
    """The face planes of the convex hull of `points` (None for a piece too thin to have a volume)."""
    try:
        hull = ConvexHull(points)
    except QhullError:
        return None
    return hull.equations[:, :3], hull.equations[:, 3]


def _column_bounds(facets: Facets, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each vertical line (x, y) of `grid` (M, 2) enters and leaves a convex piece: (bottom, top), NaN for a
    line that misses it."""
    normals, offsets = facets
    values = grid @ normals[:, :2].T + offsets  # (M, F): n_xy . (x, y) + d
    up, down = normals[:, 2] > FLAT, normals[:, 2] < -FLAT
    top = (-values[:, up] / normals[up, 2]).min(axis=1) if up.any() else np.full(len(grid), np.inf)
    bottom = (-values[:, down] / normals[down, 2]).max(axis=1) if down.any() else np.full(len(grid), -np.inf)
    sides = ~(up | down)
    inside = (values[:, sides] <= 1e-9).all(axis=1) & (bottom <= top + 1e-9)
    return np.where(inside, bottom, np.nan), np.where(inside, top, np.nan)


def placed_pieces(entry: CatalogObject, rotation: np.ndarray, position: np.ndarray) -> list[np.ndarray]:
    """The vertices of an object's convex pieces at a pose (world frame)."""
    return [piece @ rotation.T + position for piece in convex_pieces(entry)]


def _shared_grid(pieces: list[np.ndarray], others: list[np.ndarray]) -> np.ndarray | None:
    """Vertical lines GRID_STEP apart (x, y, (M, 2)) over the box where both sets of pieces' outlines reach."""
    low = np.maximum(
        np.min([p[:, :2].min(axis=0) for p in pieces], axis=0), np.min([o[:, :2].min(axis=0) for o in others], axis=0)
    )
    high = np.minimum(
        np.max([p[:, :2].max(axis=0) for p in pieces], axis=0), np.max([o[:, :2].max(axis=0) for o in others], axis=0)
    )
    if (high < low).any():
        return None
    xs = np.append(np.arange(low[0], high[0], GRID_STEP), high[0])
    ys = np.append(np.arange(low[1], high[1], GRID_STEP), high[1])
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)


def drop_height(pieces: list[np.ndarray], support: list[np.ndarray]) -> float | None:
    """How far up `pieces` (an object's convex pieces at some height) must move so that, lowered straight down,
    they just touch the `support`'s pieces (negative: how far down); None when no vertical line meets both."""
    grid = _shared_grid(pieces, support)
    if grid is None:
        return None
    bottom = np.full(len(grid), np.inf)
    top = np.full(len(grid), -np.inf)
    for piece in pieces:
        facets = _facets(piece)
        if facets is not None:
            bottom = np.fmin(bottom, _column_bounds(facets, grid)[0])
    for piece in support:
        facets = _facets(piece)
        if facets is not None:
            top = np.fmax(top, _column_bounds(facets, grid)[1])
    gaps = top - bottom
    gaps = gaps[np.isfinite(gaps)]
    return float(gaps.max()) if len(gaps) else None


def overlap_depth(pieces: list[np.ndarray], others: list[np.ndarray]) -> float:
    """How deep two placed objects interpenetrate along the vertical (m): the longest stretch of a vertical line
    that lies inside a piece of each; 0 or less when they are apart."""
    grid = _shared_grid(pieces, others)
    if grid is None:
        return -np.inf
    spans = [_column_bounds(facets, grid) for facets in map(_facets, pieces) if facets is not None]
    other_spans = [_column_bounds(facets, grid) for facets in map(_facets, others) if facets is not None]
    depth = -np.inf
    for bottom, top in spans:
        for other_bottom, other_top in other_spans:
            shared = np.minimum(top, other_top) - np.maximum(bottom, other_bottom)  # NaN where a line misses one
            shared = shared[np.isfinite(shared)]
            if len(shared):
                depth = max(depth, float(shared.max()))
    return depth
