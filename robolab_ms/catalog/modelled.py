"""Modelled objects: triangle meshes with a real object's shape, made from a few measurements.

A generator here returns a `Model`: the object's surfaces (triangle meshes with normals and texture coordinates,
each taking one of the object's colours) and its collision as convex pieces that follow the shape: a revolved wall
cut into sectors, a swept tube cut into short segments, a rounded box's hull. `robolab catalog build` writes those
pieces (or coacd's decomposition of the surfaces, collision method `coacd`) into the object's hull file, so neither
an environment reset nor CI builds them.

The building blocks are `revolve` (a profile turned about the z axis: mugs, bowls, cans, bottles, a drill's motor),
`sweep` (a tube of varying cross-section along a path: a banana, a mug's handle, a drill's grip) and `rounded_box`.
Frame: z up, metres, the origin at the centre of the bottom of the object's main body (a mug's cup, a drill's
battery), as for procedural objects, so a modelled object can replace a procedural one in place.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any

import numpy as np

from robolab_ms.catalog.appearance import TriangleMesh
from robolab_ms.errors import UnknownNameError

DEFAULT_SEGMENTS = 48  # around a revolved surface
CREASE_DEG = 40.0  # a profile turning more than this at a point gets a sharp edge there
PIECE_TOLERANCE = 0.0015  # m: how far a convex piece may fill in a concave stretch of the profile
STEEL = (0.58, 0.58, 0.6)  # a can's lid and base, a drill's nose (light metal, which reflects the room)

Profile = Sequence[Sequence[float]]  # (r, z) points


@dataclass(frozen=True)
class Surface:
    """One surface of a modelled object: a triangle mesh in the object frame and how it looks. `tint` picks the
    object's colour (0 the first, 1 the second, the last one when it has fewer); `kind` replaces the texture kind
    the object's class gives that colour (a kind of robolab_ms.catalog.appearance.SURFACES); `rgb` replaces the
    colour; `shade` multiplies it (below 1: darker, a banana's stem)."""

    mesh: TriangleMesh
    tint: int = 0
    kind: str | None = None
    rgb: tuple[float, float, float] | None = None
    shade: float = 1.0


@dataclass(frozen=True)
class Model:
    """A modelled object: its surfaces, its convex collision pieces (vertex arrays, object frame) and, for a
    container, its inner size (x, y, z)."""

    surfaces: tuple[Surface, ...]
    pieces: tuple[np.ndarray, ...]
    interior: tuple[float, float, float] | None = None

    @property
    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds of the surfaces, [[min x, y, z], [max x, y, z]]."""
        points = np.concatenate([surface.mesh.vertices for surface in self.surfaces])
        return np.stack([points.min(axis=0), points.max(axis=0)])

    def solid(self):
        """All surfaces as one trimesh.Trimesh, vertices merged by position (what coacd decomposes)."""
        import trimesh

        vertices, triangles, offset = [], [], 0
        for surface in self.surfaces:
            vertices.append(surface.mesh.vertices)
            triangles.append(surface.mesh.triangles + offset)
            offset += len(surface.mesh.vertices)
        return trimesh.Trimesh(np.concatenate(vertices), np.concatenate(triangles), process=True)

    def digest(self) -> str:
        """A short hash of the surfaces and pieces: changes whenever a generator's output does."""
        digest = hashlib.sha256()
        for array in [s.mesh.vertices for s in self.surfaces] + list(self.pieces):
            digest.update(np.round(np.asarray(array, dtype=np.float64), 7).tobytes())
        return digest.hexdigest()[:16]


# ---------------------------------------------------------------------------------------------------- building blocks
def _normalised(vectors: np.ndarray) -> np.ndarray:
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1, keepdims=True), 1e-12)


def _cross_section(angles: np.ndarray, exponent: float) -> tuple[np.ndarray, np.ndarray]:
    """Points of the unit superellipse |x|^e + |y|^e = 1 at polar `angles` (a circle for e = 2, a rounded square
    for larger e), and their derivatives with respect to the angle."""

    def points(theta: np.ndarray) -> np.ndarray:
        c, s = np.cos(theta), np.sin(theta)
        scale = (np.abs(c) ** exponent + np.abs(s) ** exponent) ** (-1.0 / exponent)
        return np.stack([c * scale, s * scale], axis=-1)

    step = 1e-5
    return points(angles), (points(angles + step) - points(angles - step)) / (2 * step)


def _remove_degenerate(mesh: TriangleMesh) -> TriangleMesh:
    a, b, c = (mesh.vertices[mesh.triangles[:, i]] for i in range(3))
    keep = np.linalg.norm(np.cross(b - a, c - a), axis=1) > 1e-12
    return replace(mesh, triangles=mesh.triangles[keep])


def revolve(
    profile: Profile,
    segments: int = DEFAULT_SEGMENTS,
    squareness: float | Sequence[float] = 0.0,
    tints: Sequence[int] | None = None,
    crease_deg: float = CREASE_DEG,
) -> list[tuple[TriangleMesh, int]]:
    """A profile of (r, z) points turned about the z axis. Going along the profile, the outside is on the right
    (a solid's profile runs from the axis at the bottom out, up and back in to the axis at the top; a vessel's
    continues over its rim and down its inside). `squareness` (0 to 1, one value or one per profile point) makes the
    cross-section a rounded square. `tints` gives a colour index per profile segment; each run of equal ones becomes one mesh, with u going around
    and v along the profile (0 at the run's end, 1 at its start). Returns (mesh, tint) pairs."""
    points = np.asarray(profile, dtype=float)
    tints = list(tints) if tints is not None else [0] * (len(points) - 1)
    exponents = 2.0 + 8.0 * np.broadcast_to(np.asarray(squareness, dtype=float), (len(points),))
    angles = np.linspace(0.0, 2 * math.pi, segments + 1)
    sections = {e: _cross_section(angles, e) for e in set(exponents.tolist())}
    tangents = _normalised(np.diff(points, axis=0))
    cos_crease = math.cos(math.radians(crease_deg))

    def ring_tangent(segment: int, end: int) -> np.ndarray:
        """The tangent whose normal the ring at `end` (0 start, 1 end) of `segment` uses: smooth unless a crease."""
        neighbour = segment - 1 if end == 0 else segment + 1
        if 0 <= neighbour < len(tangents) and tangents[segment] @ tangents[neighbour] > cos_crease:
            return _normalised(tangents[segment] + tangents[neighbour])
        return tangents[segment]

    meshes = []
    start = 0
    while start < len(tangents):
        stop = start
        while stop + 1 < len(tangents) and tints[stop + 1] == tints[start]:
            stop += 1
        lengths = np.linalg.norm(np.diff(points[start : stop + 2], axis=0), axis=1)
        along = np.concatenate([[0.0], np.cumsum(lengths)]) / max(lengths.sum(), 1e-12)
        vertices, normals, uvs, triangles = [], [], [], []
        for index, segment in enumerate(range(start, stop + 1)):
            base = len(vertices) * (segments + 1)
            for end in (0, 1):
                r, z = points[segment + end]
                t_r, t_z = ring_tangent(segment, end)
                direction, derivative = sections[float(exponents[segment + end])]
                turn = direction[:, 0] * derivative[:, 1] - direction[:, 1] * derivative[:, 0]
                vertices.append(np.column_stack([r * direction, np.full(segments + 1, z)]))
                normal = np.column_stack([t_z * derivative[:, 1], -t_z * derivative[:, 0], -t_r * turn])
                normals.append(_normalised(normal))
                v = 1.0 - along[index + end]
                uvs.append(np.column_stack([angles / (2 * math.pi), np.full(segments + 1, v)]))
            j = np.arange(segments)
            a, b = base + j, base + segments + 1 + j
            triangles += [np.column_stack([a, a + 1, b + 1]), np.column_stack([a, b + 1, b])]
        mesh = TriangleMesh(
            np.concatenate(vertices), np.concatenate(triangles), np.concatenate(normals), np.concatenate(uvs)
        )
        meshes.append((_remove_degenerate(mesh), tints[start]))
        start = stop + 1
    return meshes


def _frames(path: np.ndarray, up: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tangents, normals (the `up` direction made perpendicular to each tangent) and binormals along a path."""
    tangents = _normalised(np.gradient(path, axis=0))
    up_vector = np.asarray(up, dtype=float)
    normals = _normalised(up_vector - (tangents @ up_vector)[:, None] * tangents)
    binormals = np.cross(tangents, normals)
    return tangents, normals, binormals


def sweep(
    path: np.ndarray,
    half_widths: np.ndarray,
    up: Sequence[float] = (0.0, 0.0, 1.0),
    sides: int = 24,
    lobes: int = 0,
    lobe_depth: float = 0.0,
    squareness: float = 0.0,
) -> tuple[TriangleMesh, np.ndarray]:
    """A closed tube along `path` (M, 3): at each point an ellipse with half widths (M, 2) across the path (the
    first along the binormal, the second along `up` made perpendicular to the path), a rounded rectangle with
    `squareness` (0 to 1: a drill's grip), optionally with `lobes` soft ridges (`lobe_depth`, a fraction of the
    width: a banana's angular section). Flat caps close the ends. A side of the section, not a corner, faces each
    of the four directions across the path (fingers closing on the tube meet a face). Returns the mesh (u around,
    v along the path) and the rings of points (M, sides, 3), which make its convex pieces."""
    path = np.asarray(path, dtype=float)
    half_widths = np.asarray(half_widths, dtype=float)
    tangents, normals, binormals = _frames(path, up)
    phi = (np.arange(sides + 1) + 0.5) * 2 * math.pi / sides
    section, derivative = _cross_section(phi, 2.0 + 8.0 * squareness)
    lobe = 1.0 + lobe_depth * np.cos(lobes * phi) if lobes else np.ones_like(phi)
    across = half_widths[:, :1, None] * (section[:, 0] * lobe)[None, :, None] * binormals[:, None, :]
    above = half_widths[:, 1:, None] * (section[:, 1] * lobe)[None, :, None] * normals[:, None, :]
    rings = path[:, None, :] + across + above  # (M, sides + 1, 3)
    normal = (derivative[None, :, 1:] * half_widths[:, None, 1:]) * binormals[:, None, :] - (
        derivative[None, :, :1] * half_widths[:, None, :1]
    ) * normals[:, None, :]
    count = len(path)
    lengths = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    v = 1.0 - lengths / max(lengths[-1], 1e-12)
    uvs = np.stack(np.broadcast_arrays(phi[None, :] / (2 * math.pi), v[:, None]), axis=-1)
    vertices = [rings.reshape(-1, 3)]
    normal_list = [_normalised(normal).reshape(-1, 3)]
    uv_list = [uvs.reshape(-1, 2)]
    i, j = np.meshgrid(np.arange(count - 1), np.arange(sides), indexing="ij")
    a = (i * (sides + 1) + j).ravel()
    b = a + sides + 1
    triangles = [np.stack([a, b, b + 1], axis=1), np.stack([a, b + 1, a + 1], axis=1)]
    for end, sign in ((0, -1.0), (count - 1, 1.0)):  # flat caps: a fan around the end's centre, facing away
        start = sum(len(block) for block in vertices)
        vertices.append(np.concatenate([path[end : end + 1], rings[end]]))
        normal_list.append(np.tile(sign * tangents[end], (sides + 2, 1)))
        uv_list.append(np.concatenate([[[0.5, 0.5]], 0.5 + 0.5 * section]))
        k = np.arange(sides)
        fan = np.column_stack([np.full(sides, start), start + 1 + k, start + 2 + k])
        triangles.append(fan[:, [0, 2, 1]] if sign > 0 else fan)
    mesh = TriangleMesh(
        np.concatenate(vertices), np.concatenate(triangles), np.concatenate(normal_list), np.concatenate(uv_list)
    )
    return _outward(_remove_degenerate(mesh)), rings[:, :-1]


def _outward(mesh: TriangleMesh) -> TriangleMesh:
    """The mesh with its triangles wound counter-clockwise seen from outside (a positive enclosed volume)."""
    a, b, c = (mesh.vertices[mesh.triangles[:, i]] for i in range(3))
    if float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) < 0:
        return replace(mesh, triangles=mesh.triangles[:, [0, 2, 1]])
    return mesh


def _convex_surface(points: np.ndarray, size: np.ndarray, centre: np.ndarray, normal_of=None) -> TriangleMesh:
    """The convex hull of `points` as a mesh whose faces are split by the axis they face: each side of the box
    `size` around `centre` maps the whole texture (u across it, v down it; top and bottom along x and y).
    `normal_of(points)` gives smooth vertex normals; without it every face is flat."""
    import trimesh

    hull = trimesh.PointCloud(points).convex_hull
    face_normals = np.asarray(hull.face_normals)
    axes = np.argmax(np.abs(face_normals), axis=1)
    signs = np.sign(face_normals[np.arange(len(axes)), axes]).astype(int)
    keys = {}
    vertices, normals, uvs, triangles = [], [], [], []
    low = centre - size / 2
    for face, axis, sign, face_normal in zip(np.asarray(hull.faces), axes, signs, face_normals):
        corner_ids = []
        for vertex in face:
            key = (int(vertex), int(axis), int(sign)) if normal_of is not None else (int(vertex), len(triangles))
            if key not in keys:
                point = np.asarray(hull.vertices[vertex])
                fraction = (point - low) / size
                u_axis, v_axis = {0: (1, 2), 1: (0, 2), 2: (0, 1)}[int(axis)]
                v = 1.0 - fraction[v_axis] if axis != 2 else fraction[v_axis]
                keys[key] = len(vertices)
                vertices.append(point)
                normals.append(normal_of(point[None])[0] if normal_of is not None else face_normal)
                uvs.append([fraction[u_axis], v])
            corner_ids.append(keys[key])
        triangles.append(corner_ids)
    return TriangleMesh(np.asarray(vertices), np.asarray(triangles), np.asarray(normals), np.asarray(uvs))


def rounded_box(
    size: Sequence[float], radius: float, centre: Sequence[float] = (0, 0, 0)
) -> tuple[TriangleMesh, np.ndarray]:
    """A box of full `size` with its edges and corners rounded by `radius`, centred at `centre`. Returns the mesh
    and the points of its chamfered hull (a convex piece close to it, with few vertices)."""
    size_array, centre_array = np.asarray(size, dtype=float), np.asarray(centre, dtype=float)
    radius = min(radius, float(size_array.min()) / 2 * 0.999)
    inner = size_array / 2 - radius
    steps = np.linspace(0.0, math.pi / 2, 4)
    octant = np.array(
        [[math.cos(a) * math.cos(b), math.cos(a) * math.sin(b), math.sin(a)] for a in steps for b in steps]
    )
    points, chamfer = [], []
    for signs in np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float):
        points.append(centre_array + signs * (inner + radius * octant))
        chamfer.append(centre_array + signs * (inner + radius * np.eye(3)))
    points_array = np.unique(np.round(np.concatenate(points), 9), axis=0)

    def normal_of(p: np.ndarray) -> np.ndarray:
        local = p - centre_array
        return _normalised(local - np.clip(local, -inner, inner))

    return _convex_surface(points_array, size_array, centre_array, normal_of), np.concatenate(chamfer)


# ---------------------------------------------------------------------------------------------------- convex pieces
def _sector_angles(sectors: int) -> np.ndarray:
    """The corner angles of a `sectors`-sided polygon about the z axis with a side (not a corner) facing each of
    +x, +y, -x and -y (for `sectors` a multiple of 4): an object on its side rests on a face, as a cylinder would."""
    return (np.arange(sectors) + 0.5) * 2 * math.pi / sectors


def _ring(radius: float, z: float, sectors: int, exponent: float = 2.0) -> np.ndarray:
    """A polygon of `sectors` corners at height `z` around the section of `radius`: for a circle, its sides touch
    the circle (the collision reaches the surface all round, and no further than its corners)."""
    direction, _ = _cross_section(_sector_angles(sectors), exponent)
    if exponent == 2.0:
        radius = radius / math.cos(math.pi / sectors)
    return np.column_stack([radius * direction, np.full(sectors, z)])


def _overshoot(band: np.ndarray) -> float:
    """How far (m, radially) the convex hull of a solid band of revolution, given by its (r, z) silhouette points,
    lies outside the silhouette."""
    from scipy.spatial import ConvexHull

    if len(band) < 3:
        return 0.0
    polygon = np.concatenate([band, [[0.0, band[:, 1].min()], [0.0, band[:, 1].max()]]])
    try:
        hull = polygon[ConvexHull(polygon).vertices]
    except Exception:  # noqa: BLE001 - collinear points: a flat hull has no overshoot
        return 0.0
    worst = 0.0
    for r, z in band[1:-1]:
        edges = zip(hull, np.roll(hull, -1, axis=0))
        reach = [
            a[0] + (b[0] - a[0]) * (z - a[1]) / (b[1] - a[1])
            for a, b in edges
            if (a[1] - z) * (b[1] - z) <= 0 and a[1] != b[1]
        ]
        worst = max(worst, max(reach, default=r) - r)
    return worst


def _bands(silhouette: np.ndarray, tolerance: float = PIECE_TOLERANCE) -> list[np.ndarray]:
    """The silhouette (r, z points, bottom to top) cut into as few bands as keep each band's hull within
    `tolerance` of it."""
    bands, start = [], 0
    while start < len(silhouette) - 1:
        stop = start + 1
        while stop + 1 < len(silhouette) and _overshoot(silhouette[start : stop + 2]) <= tolerance:
            stop += 1
        bands.append(silhouette[start : stop + 1])
        start = stop
    return bands


def solid_pieces(
    silhouette: Profile,
    sectors: int = 24,
    squareness: float | Sequence[float] = 0.0,
    tolerance: float = PIECE_TOLERANCE,
) -> list[np.ndarray]:
    """Convex pieces of a solid of revolution given by its outer silhouette (r, z points from bottom to top; a
    `squareness` per point, or one for all): one frustum-like hull per band."""
    silhouette = np.asarray(silhouette, dtype=float)
    exponents = 2.0 + 8.0 * np.broadcast_to(np.asarray(squareness, dtype=float), (len(silhouette),))
    pieces, start = [], 0
    for band in _bands(silhouette, tolerance):
        rings = [_ring(r, z, sectors, e) for (r, z), e in zip(band, exponents[start : start + len(band)])]
        pieces.append(np.concatenate(rings))
        start += len(band) - 1
    return pieces


def wall_pieces(
    outer: np.ndarray,
    inner: np.ndarray,
    sectors: int,
    rim: np.ndarray | None = None,
    tolerance: float = PIECE_TOLERANCE,
) -> list[np.ndarray]:
    """Convex pieces of a vessel's wall: `outer` and `inner` (r, z) points in pairs across the wall, bottom to top,
    cut into bands (as few as keep each piece within `tolerance` of the inside, where it would fill the cavity; at
    most 12 pairs each) and `sectors` sectors. The top band also takes the `rim`'s (r, z) points."""
    pieces = []
    start = 0
    while start < len(inner) - 1:
        stop = start + 1
        while stop + 1 < len(inner) and _concavity(inner[start : stop + 2]) <= tolerance:
            stop += 1
        band = np.concatenate([outer[start : stop + 1], inner[start : stop + 1]])
        if stop == len(inner) - 1 and rim is not None:
            band = np.concatenate([band, rim])
        corners = _sector_angles(sectors)
        reach = 1.0 / math.cos(math.pi / sectors)  # the sides touch the outer and inner circles
        for sector in range(sectors):
            angles = corners[[sector, (sector + 1) % sectors]]
            pieces.append(
                np.array([[reach * r * math.cos(a), reach * r * math.sin(a), z] for r, z in band for a in angles])
            )
        start = stop
    return pieces


def _concavity(inner: np.ndarray) -> float:
    """How far (m) the chord from the first to the last inner point passes inside the cavity of the points between
    (a bowl's inner wall curves away from the chord: the piece would fill that gap)."""
    a, b = inner[0], inner[-1]
    chord = b - a
    normal = np.array([chord[1], -chord[0]]) / max(float(np.linalg.norm(chord)), 1e-12)  # pointing out of the wall
    return float(max(((p - a) @ normal for p in inner[1:-1]), default=0.0))


def tube_pieces(rings: np.ndarray, per_piece: int = 2) -> list[np.ndarray]:
    """Convex pieces of a swept tube: the hull of every `per_piece` consecutive segments' rings."""
    pieces = []
    for start in range(0, len(rings) - 1, per_piece):
        pieces.append(rings[start : start + per_piece + 1].reshape(-1, 3))
    return pieces


def _arc(centre: Sequence[float], radius: float, start_deg: float, stop_deg: float, count: int) -> np.ndarray:
    angles = np.radians(np.linspace(start_deg, stop_deg, count))
    return np.column_stack([centre[0] + radius * np.cos(angles), centre[1] + radius * np.sin(angles)])


# ---------------------------------------------------------------------------------------------------- generators
def revolved(profile: list[list[float]], squareness: float = 0.0) -> Model:
    """Any solid of revolution: `profile` is its outline as [r, z] points (m) from the axis at the bottom, out and
    up, and back to the axis at the top (r = 0 at both ends). One colour; collision by bands of the outline."""
    points = np.asarray(profile, dtype=float)
    if len(points) < 3 or points[0, 0] != 0.0 or points[-1, 0] != 0.0:
        raise ValueError("the profile needs at least 3 points and must start and end on the axis (r = 0)")
    if np.any(np.linalg.norm(np.diff(points, axis=0), axis=1) < 1e-6):
        raise ValueError("two consecutive profile points coincide")
    surfaces = tuple(Surface(mesh, tint) for mesh, tint in revolve(points, squareness=squareness))
    outline = points[points[:, 0] > 0]
    outline = outline[np.argsort(outline[:, 1], kind="stable")]
    return _based(Model(surfaces, tuple(solid_pieces(outline, squareness=squareness))))


def _based(model: Model) -> Model:
    """The model moved up or down so that its lowest point is at z = 0."""
    bottom = float(model.bounds[0, 2])
    if abs(bottom) < 1e-9:
        return model
    shift = np.array([0.0, 0.0, -bottom])
    surfaces = tuple(replace(s, mesh=replace(s.mesh, vertices=s.mesh.vertices + shift)) for s in model.surfaces)
    return Model(surfaces, tuple(piece + shift for piece in model.pieces), model.interior)


def _resampled(curve: np.ndarray, step: float = 0.003) -> np.ndarray:
    """A polyline resampled at about `step` apart (its corners may be rounded off by up to `step`)."""
    lengths = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(curve, axis=0), axis=1))])
    count = max(8, int(math.ceil(lengths[-1] / step)) + 1)
    at = np.linspace(0.0, lengths[-1], count)
    return np.column_stack([np.interp(at, lengths, curve[:, 0]), np.interp(at, lengths, curve[:, 1])])


def _vessel(
    outer: np.ndarray,
    wall: float,
    floor: float,
    sectors: int,
    radius: float,
    height: float,
    fillet: float = 0.0,
    tolerance: float = PIECE_TOLERANCE,
) -> tuple[list[tuple[TriangleMesh, int]], list[np.ndarray], tuple[float, float, float]]:
    """Surfaces, convex pieces and interior of an open vessel. `outer` is its outside as (r, z) points from the edge
    of the flat base up to the rim; the inside is that curve offset inwards by `wall`, down to a flat floor `floor`
    above the base (with a `fillet` where it meets the wall); a half-round rim joins them. The whole is then scaled
    to exactly `radius` and `height` outside. The wall's pieces keep within `tolerance` of the inside."""
    curve = _resampled(np.asarray(outer, dtype=float))
    tangent = _normalised(np.gradient(curve, axis=0))
    inner = curve + wall * np.column_stack([-tangent[:, 1], tangent[:, 0]])
    rim_centre = (curve[-1] + inner[-1]) / 2
    start = math.degrees(math.atan2(curve[-1][1] - rim_centre[1], curve[-1][0] - rim_centre[0]))
    rim = _arc(rim_centre, wall / 2, start, start + 180.0, 7)[1:-1]
    inside = inner[inner[:, 1] >= floor + fillet - 1e-9][::-1]
    lowest = float(inside[-1, 0])  # the inner wall's lowest point: the floor meets the wall here
    if fillet > 0:
        corner = _arc((lowest - fillet, floor + fillet), fillet, 0.0, -90.0, 5)[1:]
    else:
        corner = np.array([[lowest, floor]])
    profile = np.concatenate([[[0.0, 0.0]], curve, rim, inside, corner, [[0.0, floor]]])
    scale = np.array([radius / profile[:, 0].max(), height / profile[:, 1].max()])
    profile, curve, inner, rim = (points * scale for points in (profile, curve, inner, rim))
    floor *= scale[1]
    keep = np.concatenate([[True], np.linalg.norm(np.diff(profile, axis=0), axis=1) > 1e-7])
    meshes = revolve(profile[keep])
    floor_radius = float(np.interp(floor, np.maximum.accumulate(curve[:, 1]), curve[:, 0]))
    pieces = [np.concatenate([_ring(float(curve[0, 0]), 0.0, sectors), _ring(floor_radius, floor, sectors)])]
    above = inner[:, 1] >= floor - 1e-9
    pieces += wall_pieces(curve[above], inner[above], sectors, rim, tolerance)
    inner_diameter = 2 * float(inner[-1, 0])
    return meshes, pieces, (inner_diameter, inner_diameter, height - floor)


def _handle_path(radius: float, low: float, high: float, reach: float, thickness: float, count: int = 17) -> np.ndarray:
    """A mug handle's centre line in the xz plane: a D from `high` out to `reach` beyond the wall and back to
    `low`, both ends just inside the wall."""
    phi = np.linspace(-math.pi / 2, math.pi / 2, count)
    out = np.abs(np.cos(phi)) ** 0.55
    x = radius - thickness / 2 + (reach) * out
    z = (low + high) / 2 + (high - low) / 2 * np.sin(phi)
    return np.column_stack([x, np.zeros(count), z])


def mug(
    radius: float,
    height: float,
    wall: float = 0.005,
    floor: float = 0.008,
    taper: float = 0.0,
    handle_reach: float = 0.025,
    handle_thickness: float = 0.009,
    handle_width: float = 0.014,
) -> Model:
    """A mug: a revolved body of outer `radius` at the rim (`taper`: how much narrower the base is, a fraction) and
    `height`, open at the top with a rounded rim, a `wall` thick wall and a `floor` thick floor, and a D-shaped
    handle at +x reaching `handle_reach` beyond the wall (a swept tube of `handle_thickness` by `handle_width`)."""
    if wall >= radius / 2 or floor >= height / 2:
        raise ValueError("the wall or the floor is too thick for the mug's size")
    base = radius * (1 - taper)
    edge = min(0.004, base * 0.2)
    foot = _arc((base - edge, edge), edge, -90.0, 0.0, 4)
    side = [[base + (radius - base) * (z / height), z] for z in np.linspace(edge + 0.004, height, 6)]
    outer = np.concatenate([foot, side])
    meshes, pieces, interior = _vessel(outer, wall, floor, 16, radius, height, fillet=min(0.005, floor))
    thickness = min(handle_thickness, height / 4)
    path = _handle_path(radius, 0.28 * height, 0.78 * height, handle_reach, thickness)
    widths = np.tile([thickness / 2, handle_width / 2], (len(path), 1))
    handle, rings = sweep(path, widths, up=(0.0, 1.0, 0.0), sides=16)
    surfaces = tuple(Surface(mesh, tint) for mesh, tint in meshes) + (Surface(handle, 0),)
    return Model(surfaces, tuple(pieces + tube_pieces(rings, 4)), interior)


def bowl(radius: float, height: float, base_radius: float, wall: float = 0.006, flare_deg: float = 65.0) -> Model:
    """A bowl: outer `radius` at the rim, `height`, a flat foot of `base_radius`, a wall curving up from the foot
    and meeting the rim at `flare_deg` from the horizontal (90: upright), a rounded rim."""
    if base_radius >= radius or wall >= height / 3:
        raise ValueError("base_radius must be smaller than radius, and the wall thinner than a third of the height")
    flare = math.radians(min(max(flare_deg, 20.0), 90.0))
    foot = max(0.003, min(0.006, height * 0.08))
    phi = np.linspace(0.0, flare, 16)  # a quarter ellipse from the foot (horizontal) to the rim (at flare)
    curve = np.column_stack(
        [
            base_radius + (radius - base_radius) * np.sin(phi) / math.sin(flare),
            foot + (height - foot) * (1 - np.cos(phi)) / (1 - math.cos(flare)),
        ]
    )
    outer = np.concatenate([[[base_radius, 0.0]], curve])
    meshes, pieces, interior = _vessel(outer, wall, foot + wall, 16, radius, height, tolerance=0.002)
    return Model(tuple(Surface(mesh, tint) for mesh, tint in meshes), tuple(pieces), interior)


def cup(top_radius: float, bottom_radius: float, height: float, wall: float = 0.003) -> Model:
    """An open tapered cup or tumbler of outer radii `top_radius` (at the rim) and `bottom_radius`."""
    if wall >= bottom_radius / 2 or wall >= height / 4:
        raise ValueError("the wall is too thick for the cup's size")
    edge = min(0.003, bottom_radius * 0.2)
    foot = _arc((bottom_radius - edge, edge), edge, -90.0, 0.0, 4)
    side = [[bottom_radius + (top_radius - bottom_radius) * f, f * height] for f in np.linspace(0.1, 1, 6)]
    outer = np.concatenate([foot, side])
    floor = max(wall, 0.004)
    meshes, pieces, interior = _vessel(outer, wall, floor, 16, top_radius, height, fillet=min(0.003, floor))
    return Model(tuple(Surface(mesh, tint) for mesh, tint in meshes), tuple(pieces), interior)


def can(radius: float, height: float, rim: float = 0.004) -> Model:
    """A food or drink can: a labelled body (first colour) between a rolled steel base and a seamed steel lid set
    down inside its rim."""
    seam = min(rim, height / 8)
    neck = radius - seam * 0.6
    profile = [
        [0.0, seam * 0.6], [neck - seam, seam * 0.6], [neck - seam * 0.3, 0.0], [neck, 0.0], [radius, seam],
        [radius, height - seam * 1.2], [radius - seam * 0.15, height - seam * 0.8], [radius - seam * 0.15, height],
        [radius - seam * 0.7, height], [radius - seam, height - seam * 0.6], [0.0, height - seam * 0.6],
    ]  # fmt: skip
    tints = [1, 1, 1, 1, 0, 1, 1, 1, 1, 1]  # the label between the two seams
    surfaces = tuple(
        Surface(mesh, 0) if tint == 0 else Surface(mesh, 0, "metal", STEEL)
        for mesh, tint in revolve(profile, tints=tints)
    )
    # One prism, flat ends with square edges as the procedural can's cylinders: on a rounded base edge a knocked
    # can rolls away on its rim much further.
    return Model(surfaces, tuple(solid_pieces([[radius, 0.0], [radius, height]])))


def bottle(
    radius: float,
    height: float,
    neck_radius: float,
    neck_height: float,
    cap_height: float = 0.015,
    shoulder: float = 0.25,
    squareness: float = 0.0,
    cap_radius: float = 0.0,
    depth: float = 0.0,
) -> Model:
    """A bottle: a body of `radius` (a rounded square with `squareness`, e.g. a mustard bottle, rounding off
    towards the neck) with a label in the first colour, a `shoulder` (a fraction of the body's height) curving in to the neck, and a cap of
    `cap_height` (and `cap_radius`, default a little wider than the neck) in the second colour. `depth`: the
    body's full extent along y where it is flatter than wide (default 2 `radius`); the neck and cap stay round."""
    cap_r = cap_radius or neck_radius * 1.15
    body = height - neck_height - cap_height
    if body <= 0 or neck_radius >= radius or cap_r > radius:
        raise ValueError("the neck and cap must be narrower than the body, and shorter than the bottle")
    shoulder_top = body
    shoulder_bottom = body * (1 - shoulder)
    edge = min(0.005, radius * 0.2)
    phi = np.linspace(0.0, math.pi / 2, 7)
    curve = np.column_stack(
        [
            neck_radius + (radius - neck_radius) * np.cos(phi),
            shoulder_bottom + (shoulder_top - shoulder_bottom) * np.sin(phi),
        ]
    )
    cap_bottom = height - cap_height
    bevel = min(0.002, cap_height / 4)
    profile = np.concatenate(
        [
            [[0.0, 0.0]],
            _arc((radius - edge, edge), edge, -90.0, 0.0, 4),
            curve,
            [
                [neck_radius, cap_bottom],
                [cap_r, cap_bottom],
                [cap_r, height - bevel],
                [cap_r - bevel, height],
                [0.0, height],
            ],
        ]
    )
    tints = [0] * (len(profile) - 5) + [1] * 4  # the cap from its underside up

    def fading(points: np.ndarray) -> np.ndarray:  # square at the body, round from the neck up
        return squareness * np.clip((points[:, 0] - neck_radius) / (radius - neck_radius), 0.0, 1.0)

    meshes = revolve(profile, squareness=fading(profile), tints=tints)
    surfaces = []
    for mesh, tint in meshes:  # the label wraps the straight body; the shoulder and neck are plain plastic
        if tint == 0:
            surfaces += _split_label(mesh, edge, shoulder_bottom)
        else:
            surfaces.append(Surface(mesh, 1))
    silhouette = np.concatenate(
        [
            [[radius - edge, 0.0], [radius, edge]],
            curve,
            [[neck_radius, cap_bottom], [cap_r, cap_bottom], [cap_r, height]],
        ]
    )
    pieces = solid_pieces(silhouette, squareness=fading(silhouette))
    if depth and depth < 2 * radius:
        flatten = _flattener(cap_r, radius, depth / 2)
        surfaces = [replace(s, mesh=flatten(s.mesh)) for s in surfaces]
        pieces = [flatten.points(piece) for piece in pieces]
    return Model(tuple(surfaces), tuple(pieces))


class _flattener:
    """Squeezes a bottle along y: |y| beyond the neck's `keep` is scaled so that `radius` becomes `half_depth`; the
    neck and cap (within `keep` of the axis) stay round."""

    def __init__(self, keep: float, radius: float, half_depth: float) -> None:
        self.keep, self.factor = keep, (half_depth - keep) / (radius - keep)

    def points(self, points: np.ndarray) -> np.ndarray:
        y = points[:, 1]
        beyond = np.abs(y) > self.keep
        squeezed = np.where(beyond, np.sign(y) * (self.keep + (np.abs(y) - self.keep) * self.factor), y)
        return np.column_stack([points[:, 0], squeezed, points[:, 2]])

    def __call__(self, mesh: TriangleMesh) -> TriangleMesh:
        slope = np.where(np.abs(mesh.vertices[:, 1]) > self.keep, self.factor, 1.0)
        normals = mesh.normals / np.column_stack([np.ones(len(slope)), slope, np.ones(len(slope))])
        return replace(mesh, vertices=self.points(mesh.vertices), normals=_normalised(normals))


def _split_label(mesh: TriangleMesh, low: float, high: float) -> list[Surface]:
    """A bottle's body mesh as its labelled band between heights `low` and `high` (texture coordinates stretched
    over the band) and the rest in plain plastic of the same colour."""
    z = mesh.vertices[mesh.triangles].mean(axis=1)[:, 2]
    band = (z > low - 1e-6) & (z < high + 1e-6)
    surfaces = []
    for selected, kind in ((band, None), (~band, "plastic")):
        if not selected.any():
            continue
        uvs = mesh.uvs.copy()
        if kind is None:
            uvs[:, 1] = 1.0 - np.clip((mesh.vertices[:, 2] - low) / (high - low), 0, 1)
        surfaces.append(Surface(replace(mesh, triangles=mesh.triangles[selected], uvs=uvs), 0, kind))
    return surfaces


def banana(length: float, radius: float, bend_deg: float, stem_length: float = 0.015, ridges: float = 0.06) -> Model:
    """A banana lying on its side: a tube bent along an arc of `bend_deg` with `length` along its curve, thickest
    (`radius`) in the middle and tapering to a dark tip at one end and a stem at the other, its section softly
    five-sided (`ridges`, a fraction of the radius). It rests on the table along its underside."""
    bend = math.radians(bend_deg)
    count = 33
    t = np.linspace(0.0, 1.0, count)
    taper = np.clip(np.sin(math.pi * (0.04 + 0.92 * t)) ** 0.55, 0.0, 1.0)
    radii = radius * np.maximum(taper, 0.22)
    arc_radius = length / bend if bend > 0 else float("inf")
    angle = (t - 0.5) * bend
    if math.isfinite(arc_radius):
        x, y = arc_radius * np.sin(angle), arc_radius * (1 - np.cos(angle))
    else:
        x, y = (t - 0.5) * length, np.zeros(count)
    lift = 0.15 * radius * (2 * t - 1) ** 4  # the ends curl up a little
    lobed = 1.0 + ridges
    path = np.column_stack([x, y, radii * lobed + lift])
    body, rings = sweep(path, np.column_stack([radii, radii]), sides=20, lobes=5, lobe_depth=ridges)
    surfaces = [Surface(body, 0)]
    pieces = tube_pieces(rings, 4)
    tangent = _normalised(path[-1] - path[-2])
    stem_path = np.array([path[-1] - tangent * 0.002 + [0, 0, s * 0.004] for s in (0.0, 0.5, 1.0)])
    stem_path[1:] += tangent * np.array([[stem_length * 0.5], [stem_length]])
    stem_radius = max(radii[-1] * 0.7, 0.0025)
    stem, stem_rings = sweep(stem_path, np.full((3, 2), stem_radius), sides=8)
    surfaces.append(Surface(stem, 0, shade=0.45))
    pieces += tube_pieces(stem_rings, 2)
    tip_path = np.array([path[0] + _normalised(path[0] - path[1]) * s for s in (-0.004, 0.0, 0.003)])
    tip, _ = sweep(tip_path, np.full((3, 2), radii[0] * 0.9), sides=8)
    surfaces.append(Surface(tip, 0, shade=0.25))
    model = Model(tuple(surfaces), tuple(pieces))
    low, high = model.bounds
    shift = np.array([-(low[0] + high[0]) / 2, -(low[1] + high[1]) / 2, 0.0])  # centred over the origin
    moved = tuple(replace(s, mesh=replace(s.mesh, vertices=s.mesh.vertices + shift)) for s in surfaces)
    return _based(Model(moved, tuple(p + shift for p in pieces)))


def _along_x(mesh: TriangleMesh, centre: Sequence[float]) -> TriangleMesh:
    """A mesh made about the z axis turned to lie along +x (its +z to +x), moved to `centre`."""
    turn = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    return replace(mesh, vertices=mesh.vertices @ turn.T + np.asarray(centre), normals=mesh.normals @ turn.T)


def drill(height: float = 0.19, length: float = 0.205, width: float = 0.075, body_radius: float = 0.03) -> Model:
    """A cordless drill standing on its battery: a battery pack (second colour) of `width` under an upright grip,
    a motor housing of `body_radius` along +x, a clutch ring and a chuck (second colour) with a steel nose.
    `length` runs from the back of the housing to the chuck's nose; the battery is centred at the origin."""
    battery = (0.1, width, 0.05)
    axis_z = height - body_radius
    back = -0.055
    surfaces, pieces = [], []
    pack, pack_hull = rounded_box(battery, 0.008, (0.0, 0.0, battery[2] / 2))
    surfaces.append(Surface(pack, 1))
    pieces.append(pack_hull)
    grip_path = np.array([[0.0, 0.0, battery[2] - 0.01], [0.0, 0.0, (battery[2] + axis_z) / 2], [0.0, 0.0, axis_z]])
    grip_widths = np.array([[0.02, 0.016], [0.019, 0.015], [0.02, 0.016]])  # 4 cm front to back, 3.2 cm across
    grip, _ = sweep(grip_path, grip_widths, up=(0, 1, 0), sides=24, squareness=0.7)
    surfaces.append(Surface(grip, 0))
    # Its collision keeps square edges: pads closing on the grip near its top meet a flat side, not a rounded
    # edge that would squeeze the drill out (a heavy tool is held over its centre of mass, on the grip).
    _, grip_rings = sweep(grip_path, grip_widths, up=(0, 1, 0), sides=24, squareness=1.0)
    pieces += tube_pieces(grip_rings, 2)
    nose = back + length
    housing = back + 0.75 * (length - 0.05)  # the housing's front, where the clutch ring starts
    profile = [[0.0, 0.0], [body_radius * 0.75, 0.0], [body_radius * 0.95, 0.008], [body_radius, 0.025]]
    profile += [[body_radius * 0.97, housing - back - 0.02], [body_radius * 0.8, housing - back], [0.0, housing - back]]
    for mesh, _ in revolve(profile):
        surfaces.append(Surface(_along_x(mesh, (back, 0.0, axis_z)), 0))
    silhouette = np.asarray(profile[1:-1])
    pieces += [
        piece @ np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]).T + [back, 0.0, axis_z]
        for piece in solid_pieces(silhouette, sectors=16, tolerance=0.002)
    ]
    chuck_length = nose - housing
    chuck = [
        [0.0, 0.0], [body_radius * 0.85, 0.0], [body_radius * 0.85, 0.012], [0.017, 0.014], [0.017, chuck_length * 0.6],
        [0.012, chuck_length * 0.85], [0.008, chuck_length * 0.85], [0.007, chuck_length], [0.0, chuck_length],
    ]  # fmt: skip
    kinds = [1, 1, 1, 1, 1, 2, 2, 2]
    for mesh, tint in revolve(chuck, tints=kinds):
        look = Surface(_along_x(mesh, (housing, 0.0, axis_z)), 1)
        if tint == 2:  # the steel nose
            look = replace(look, kind="metal", rgb=STEEL)
        surfaces.append(look)
    pieces += [
        piece @ np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]).T + [housing, 0.0, axis_z]
        for piece in solid_pieces(np.asarray(chuck[1:-1]), sectors=12, tolerance=0.002)
    ]
    trigger, trigger_hull = rounded_box((0.012, 0.012, 0.022), 0.004, (0.026, 0.0, axis_z - body_radius - 0.006))
    surfaces.append(Surface(trigger, 1))
    pieces.append(trigger_hull)
    return Model(tuple(surfaces), tuple(pieces))


def bevelled_box(size: list[float], bevel: float = 0.003) -> Model:
    """A box or carton of full size (x, y, z) with its edges rounded by `bevel`; each side shows the whole
    printed texture."""
    mesh, hull = rounded_box(size, bevel, (0.0, 0.0, size[2] / 2))
    return Model((Surface(mesh, 0),), (hull,))


def gable_carton(size: list[float], gable: float = 0.03, cap_radius: float = 0.0, fin: float = 0.01) -> Model:
    """A gable-top carton (milk, juice) of full size (x, y, z): a box whose top is a roof `gable` high along y,
    closed by a `fin` on the ridge, with an optional pour cap (second colour) on the +x slope."""
    x, y, z = size
    if gable + fin >= z or gable > x:
        raise ValueError("the gable and fin must fit within the carton's height and depth")
    eave = z - gable - fin
    house = np.array([[sx * x / 2, sy * y / 2, h] for sx in (-1, 1) for sy in (-1, 1) for h in (0.0, eave)])
    house = np.concatenate([house, [[0.0, sy * y / 2, eave + gable] for sy in (-1, 1)]])
    surfaces = [Surface(_convex_surface(house, np.array([x, y, z]), np.array([0, 0, z / 2])), 0)]
    pieces = [house]
    fin_mesh, fin_hull = rounded_box((0.004, y, fin + 0.002), 0.0015, (0.0, 0.0, eave + gable + fin / 2 - 0.001))
    surfaces.append(Surface(fin_mesh, 0))
    pieces.append(fin_hull)
    if cap_radius > 0:
        slope = math.atan2(gable, x / 2)
        cap_height = min(0.012, fin)
        middle = np.array([x / 4, 0.0, eave + gable / 2])
        normal = np.array([math.sin(slope), 0.0, math.cos(slope)])
        profile = [
            [0.0, -0.004],
            [cap_radius, -0.004],
            [cap_radius, cap_height - 0.002],
            [cap_radius - 0.002, cap_height],
            [0.0, cap_height],
        ]
        turn = _rotation_to(normal)
        for mesh, _ in revolve(profile, segments=24):
            moved = replace(mesh, vertices=mesh.vertices @ turn.T + middle, normals=mesh.normals @ turn.T)
            surfaces.append(Surface(moved, 1, "plastic"))
        cap_points = np.concatenate([_ring(cap_radius, -0.004, 12), _ring(cap_radius, cap_height, 12)])
        pieces.append(cap_points @ turn.T + middle)
    model = Model(tuple(surfaces), tuple(pieces))
    top = float(model.bounds[1, 2])
    if top > z + 1e-6:
        raise ValueError(f"the cap stands {top - z:.3f} m above the carton's height: make cap_radius smaller")
    return model


def _joined(meshes: Sequence[TriangleMesh]) -> TriangleMesh:
    """Several meshes as one (their triangles renumbered)."""
    offsets = np.cumsum([0] + [len(mesh.vertices) for mesh in meshes[:-1]])
    return TriangleMesh(
        np.concatenate([mesh.vertices for mesh in meshes]),
        np.concatenate([mesh.triangles + offset for mesh, offset in zip(meshes, offsets)]),
        np.concatenate([mesh.normals for mesh in meshes]),
        np.concatenate([mesh.uvs for mesh in meshes]),
    )


def puzzle_cube(size: float = 0.057, bevel: float = 0.004, grid: int = 3, gap: float = 0.0022) -> Model:
    """A Rubik's-style puzzle cube of edge `size`: a body with rounded edges (first colour) and `grid` x `grid`
    square stickers on the flat of each face, one colour per face (colours 2 to 7: +z, -z, +x, -x, +y,
    -y), standing 0.4 mm proud of the body. Collision: a sharp-edged box of the full size, as the procedural cube's
    (on rounded edges the top of a stack of three cubes slid off at rest)."""
    proud = 0.0004
    body, _ = rounded_box((size - 2 * proud,) * 3, bevel, (0.0, 0.0, size / 2))
    surfaces = [Surface(body, 0)]
    cell = (size - 2 * bevel) / grid  # the stickers cover the flat of each face, clear of the rounded edges
    sticker = cell - gap
    thickness = 2 * proud + 0.0004  # its inner half is buried in the body
    faces = [((0, 0, 1), 1), ((0, 0, -1), 2), ((1, 0, 0), 3), ((-1, 0, 0), 4), ((0, 1, 0), 5), ((0, -1, 0), 6)]
    offsets = (np.arange(grid) - (grid - 1) / 2) * cell
    for normal, tint in faces:
        axis = int(np.flatnonzero(normal)[0])
        across = [i for i in range(3) if i != axis]
        extent = np.full(3, sticker)
        extent[axis] = thickness
        tiles = []
        for a in offsets:
            for b in offsets:
                centre = np.array([0.0, 0.0, size / 2])
                centre[axis] += normal[axis] * (size / 2 - thickness / 2)
                centre[across[0]] += a
                centre[across[1]] += b
                tiles.append(rounded_box(extent, min(0.0025, thickness / 2 * 0.99), centre)[0])
        surfaces.append(Surface(_joined(tiles), tint, "plastic"))  # each tile is one sticker, plain
    half = size / 2
    box = np.array([[x, y, z + half] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    return Model(tuple(surfaces), (box,))


def fruit(
    radius: float,
    height: float,
    stem_length: float = 0.0,
    dimple: float = 0.002,
    base: float = 0.35,
    tip: float = 0.0,
    lying: bool = False,
    stem_radius: float = 0.0,
    lobes: int = 0,
    lobe_depth: float = 0.0,
) -> Model:
    """A round or oval fruit: a revolved body of `radius` at its widest and `height` along its axis, resting on a
    slightly flattened end (`base`: the flat's radius, a fraction of `radius`), with a `dimple` deep at the stem
    end and a short stem (second colour) `stem_length` out of it; `tip`: a nub that long at each end instead of the
    dimple (a lime's or lemon's); `stem_radius`: the stem's radius at its foot (default 8 % of `radius`: a
    pomegranate's crown, an onion's neck are wider); `lobes` ribs running from end to end, the grooves between
    them `lobe_depth` deep (a fraction of the radius; a pumpkin's). `lying`: the axis along x, the fruit on its side (a lime, a lemon), centred at the origin in x."""
    body = height - 2 * tip
    dimple = 0.0 if tip > 0 else dimple
    flat = 0.0 if lying else base * radius
    angles = np.radians(np.linspace(-90.0, 90.0, 37))
    outline = np.column_stack([radius * np.cos(angles), body / 2 * (1 + np.sin(angles))])
    lowest = body / 2 * (1 - math.sqrt(1 - min(flat / radius, 0.99) ** 2)) if flat > 0 else 0.0
    top_r = 0.18 * radius if dimple > 0 else 0.0
    keep = (outline[:, 1] > lowest + 1e-9) & ((outline[:, 0] > top_r) | (angles < 0))
    outline = outline[keep & (outline[:, 0] > 1e-9)]
    outline = np.concatenate([[[0.0, lowest]], [[flat, lowest]] if flat > 0 else np.empty((0, 2)), outline])
    if dimple > 0:
        rim_r, rim_z = outline[-1]
        dip = [[r, rim_z - dimple * (1 + math.cos(math.pi * r / rim_r)) / 2] for r in np.linspace(rim_r, 0.0, 7)[1:]]
        outline = np.concatenate([outline, dip])
    else:
        outline = np.concatenate([outline, [[0.0, body]]])
    outline[:, 1] = (outline[:, 1] - lowest) * body / (body - lowest)  # flattened, and still `body` high
    profile = _tipped(outline, radius, tip) if tip > 0 else outline
    surfaces = [
        Surface(_lobed(mesh, lobes, lobe_depth), 0)
        for mesh, _ in revolve(profile, segments=72 if lobes else DEFAULT_SEGMENTS)
    ]
    silhouette = profile[profile[:, 0] > 1e-9]
    pieces = list(solid_pieces(silhouette, sectors=12 if lying else 24))  # a lying fruit rests on a side
    if stem_length > 0:
        stem_radius = stem_radius or max(0.08 * radius, 0.0015)
        low = float(profile[-1, 1]) - 0.001
        stem = [
            [0.0, low],
            [stem_radius, low],
            [stem_radius * 0.8, low + dimple + stem_length],
            [0.0, low + dimple + stem_length],
        ]
        surfaces += [Surface(mesh, 1, shade=0.8) for mesh, _ in revolve(stem, segments=12)]
        pieces.append(
            np.concatenate([_ring(stem_radius, low, 8), _ring(stem_radius * 0.8, low + dimple + stem_length, 8)])
        )
    model = Model(tuple(surfaces), tuple(pieces))
    if lying:
        turn = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
        top = float(model.bounds[1, 2])
        centre = (-top / 2, 0.0, radius)
        surfaces = tuple(replace(s, mesh=_along_x(s.mesh, centre)) for s in model.surfaces)
        model = Model(surfaces, tuple(piece @ turn.T + centre for piece in model.pieces))
    return _based(model)


def _lobed(mesh: TriangleMesh, lobes: int, depth: float) -> TriangleMesh:
    """A revolved mesh with `lobes` grooves `depth` deep (a fraction of the radius) running along the axis; the
    ribs keep the full radius."""
    if lobes <= 0 or depth <= 0:
        return mesh
    angle = np.arctan2(mesh.vertices[:, 1], mesh.vertices[:, 0])
    scale = 1.0 - depth * (0.5 - 0.5 * np.cos(lobes * angle)) ** 2
    vertices = mesh.vertices * np.column_stack([scale, scale, np.ones(len(scale))])
    _, at = np.unique(np.round(vertices, 9), axis=0, return_inverse=True)  # smooth across seams
    at = at.reshape(-1)
    a, b, c = (vertices[mesh.triangles[:, i]] for i in range(3))
    facing = np.cross(b - a, c - a)  # area-weighted
    summed = np.zeros((at.max() + 1, 3))
    for corner in range(3):
        np.add.at(summed, at[mesh.triangles[:, corner]], facing)
    normals = _normalised(summed[at])
    return replace(mesh, vertices=vertices, normals=normals)


def _tipped(profile: np.ndarray, radius: float, tip: float) -> np.ndarray:
    """A fruit's profile with a rounded nub `tip` long added at both ends of its axis."""
    nub = 0.12 * radius
    bottom = [[0.0, 0.0], [nub * 0.6, 0.2 * tip], [nub, tip * 0.8]]
    top_z = float(profile[-1, 1]) + 2 * tip
    top = [[nub, top_z - 0.8 * tip], [nub * 0.6, top_z - 0.2 * tip], [0.0, top_z]]
    middle = profile[(profile[:, 0] > nub * 1.5)] + [0.0, tip]
    return np.concatenate([bottom, middle, top])


def bagel(radius: float, height: float, hole_radius: float, flatness: float = 0.3) -> Model:
    """A bagel: a ring of outer `radius` and `height` round a hole of `hole_radius`, its section a rounded
    oblong (`flatness` 0: round, 1: nearly square), lying flat."""
    centre = (radius + hole_radius) / 2
    half_width, half_height = (radius - hole_radius) / 2, height / 2
    exponent = 2.0 + 4.0 * flatness
    angles = np.radians(np.linspace(-90.0, 270.0, 49))
    cos, sin = np.cos(angles), np.sin(angles)
    section = np.column_stack(
        [
            centre + half_width * np.sign(cos) * np.abs(cos) ** (2 / exponent),
            half_height + half_height * np.sign(sin) * np.abs(sin) ** (2 / exponent),
        ]
    )
    surfaces = tuple(Surface(mesh, 0) for mesh, _ in revolve(section, crease_deg=60.0))
    outer, inner = section[:25], section[48:23:-1]  # bottom to top, the outside and the hole's side in pairs
    pieces = wall_pieces(outer, inner, sectors=16, tolerance=0.002)
    return _based(Model(surfaces, tuple(pieces)))


def _rotation_to(direction: np.ndarray) -> np.ndarray:
    """The rotation turning +z to `direction` (a unit vector) about the axis square to both."""
    axis = np.cross([0.0, 0.0, 1.0], direction)
    sine, cosine = float(np.linalg.norm(axis)), float(direction[2])
    if sine < 1e-12:
        return np.eye(3)
    k = axis / sine
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sine * cross + (1 - cosine) * cross @ cross


GENERATORS: dict[str, Callable[..., Model]] = {
    "revolved": revolved,
    "mug": mug,
    "bowl": bowl,
    "cup": cup,
    "can": can,
    "bottle": bottle,
    "banana": banana,
    "drill": drill,
    "bevelled_box": bevelled_box,
    "gable_carton": gable_carton,
    "puzzle_cube": puzzle_cube,
    "fruit": fruit,
    "bagel": bagel,
}
PARAM_LIMITS = {"squareness": (0.0, 1.0), "taper": (0.0, 0.5), "shoulder": (0.0, 1.0), "ridges": (0.0, 0.2),
                "bend_deg": (0.0, 270.0), "flare_deg": (20.0, 90.0),
                "base": (0.0, 0.9), "flatness": (0.0, 1.0), "lobes": (0, 32), "lobe_depth": (0.0, 0.3), "grid": (1, 9)}  # fmt: skip


def generate(generator: str, params: dict[str, Any]) -> Model:
    """Run a named modelled generator with the catalog's parameters (made once per process and parameters)."""
    if generator not in GENERATORS:
        raise UnknownNameError("modelled generator", generator, GENERATORS)
    return _generate(generator, json.dumps(params, sort_keys=True))


@lru_cache(maxsize=None)
def _generate(generator: str, params_text: str) -> Model:
    return GENERATORS[generator](**json.loads(params_text))
