"""Outlines seen from above: the corners of the convex polygon (x, y) an object covers, and how two outlines meet.

A scene's layout check and footprints (`robolab_ms.scene.spec.footprint`), the per-episode jitter, the object
variations and the scene generator's solver all reason about objects through these outlines: corners of a convex,
counter-clockwise polygon in metres.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull

from robolab_ms.catalog import CatalogObject

_OUTLINE_POINTS: dict[int, tuple[CatalogObject, np.ndarray]] = {}


def outline_points(entry: CatalogObject) -> np.ndarray:
    """The corners of the convex hull of an object's collision points (object frame): all a footprint needs."""
    cached = _OUTLINE_POINTS.get(id(entry))
    if cached is None or cached[0] is not entry:
        points = entry.points
        cached = (entry, points[ConvexHull(points).vertices])
        _OUTLINE_POINTS[id(entry)] = cached
    return cached[1]


def outlines_overlap(a: np.ndarray, b: np.ndarray) -> float:
    """How deep two convex polygons overlap (m); 0 or less when they are apart (separating axes)."""
    depth = math.inf
    for polygon in (a, b):
        edges = np.roll(polygon, -1, axis=0) - polygon
        normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        pa, pb = a @ normals.T, b @ normals.T
        gaps = np.minimum(pa.max(0), pb.max(0)) - np.maximum(pa.min(0), pb.min(0))
        depth = min(depth, float(gaps.min()))
    return depth


def outline_inside(inner: np.ndarray, outer: np.ndarray, tolerance: float) -> bool:
    """Whether convex polygon `inner` lies within convex, counter-clockwise polygon `outer`."""
    edges = np.roll(outer, -1, axis=0) - outer
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)  # outward for a counter-clockwise polygon
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return bool((inner @ normals.T <= (outer * normals).sum(1) + tolerance).all())
