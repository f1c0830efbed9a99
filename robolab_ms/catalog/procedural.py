"""Procedural object generators: each turns a few parameters into primitive parts.

A part is one primitive (box, sphere, capsule, cylinder) with its pose in the object frame and a colour. The same
parts are used for rendering and, exactly, for collision. The object frame has z up and its origin at the centre of
the bottom face, so an object rests on a surface when its origin is on that surface.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robolab_ms.errors import UnknownNameError

Quat = tuple[float, float, float, float]  # (w, x, y, z), SAPIEN's order
IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Part:
    """One primitive. `size` is half-extents (box), (radius,) (sphere), (radius, half_length) (capsule and
    cylinder, axis along the part's local x, as in SAPIEN)."""

    shape: str
    size: tuple[float, ...]
    position: tuple[float, float, float]
    rotation: Quat = IDENTITY

    def volume(self) -> float:
        if self.shape == "box":
            return 8.0 * math.prod(self.size)
        if self.shape == "sphere":
            return 4.0 / 3.0 * math.pi * self.size[0] ** 3
        radius, half_length = self.size
        if self.shape == "cylinder":
            return math.pi * radius**2 * 2 * half_length
        return math.pi * radius**2 * 2 * half_length + 4.0 / 3.0 * math.pi * radius**3  # capsule

    def surface_points(self) -> np.ndarray:
        """Points on the part's surface, in the object frame (for bounds and convex hulls)."""
        if self.shape == "box":
            local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * self.size
        elif self.shape == "sphere":
            local = _sphere_points(self.size[0])
        else:
            radius, half_length = self.size
            angles = np.linspace(0, 2 * math.pi, 16, endpoint=False)
            ring = np.stack([np.zeros_like(angles), radius * np.cos(angles), radius * np.sin(angles)], axis=1)
            local = np.concatenate([ring + [-half_length, 0, 0], ring + [half_length, 0, 0]])
            if self.shape == "capsule":
                cap = _sphere_points(radius)
                local = np.concatenate([local, cap + [-half_length, 0, 0], cap + [half_length, 0, 0]])
        return local @ quat_to_matrix(self.rotation).T + np.asarray(self.position)


def _sphere_points(radius: float) -> np.ndarray:
    golden = math.pi * (3.0 - math.sqrt(5.0))
    index = np.arange(64)
    z = 1 - 2 * (index + 0.5) / 64
    r = np.sqrt(1 - z * z)
    return radius * np.stack([r * np.cos(golden * index), r * np.sin(golden * index), z], axis=1)


def quat_to_matrix(q: Quat) -> np.ndarray:
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def axis_angle_quat(axis: tuple[float, float, float], angle: float) -> Quat:
    axis_array = np.asarray(axis, dtype=float)
    axis_array /= np.linalg.norm(axis_array)
    s = math.sin(angle / 2)
    return (math.cos(angle / 2), *(float(a * s) for a in axis_array))


def quat_multiply(a: Quat, b: Quat) -> Quat:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    )


X_TO_Z: Quat = axis_angle_quat((0, 1, 0), -math.pi / 2)  # turns a part's x axis to the object's z axis

# ---------------------------------------------------------------------------------------------------- generators


def box(size: list[float]) -> list[Part]:
    """A solid box of full size (x, y, z)."""
    half = tuple(s / 2 for s in size)
    return [Part("box", half, (0.0, 0.0, half[2]))]


def cylinder(radius: float, height: float) -> list[Part]:
    """An upright solid cylinder (cans, pucks)."""
    return [Part("cylinder", (radius, height / 2), (0.0, 0.0, height / 2), X_TO_Z)]


def sphere(radius: float, stem_length: float = 0.0) -> list[Part]:
    """A ball, optionally with a short stem on top (apples, oranges)."""
    parts = [Part("sphere", (radius,), (0.0, 0.0, radius))]
    if stem_length > 0:
        stem_radius = max(radius * 0.06, 0.002)
        parts.append(Part("capsule", (stem_radius, stem_length / 2), (0.0, 0.0, 2 * radius), X_TO_Z))
    return parts


def arc_capsules(length: float, radius: float, bend_deg: float, segments: int = 5) -> list[Part]:
    """Tapered capsules along a flat arc lying on the table (a banana)."""
    bend = math.radians(bend_deg)
    arc_radius = length / bend
    parts = []
    for i in range(segments):
        t = (i + 0.5) / segments
        angle = (t - 0.5) * bend
        x = arc_radius * math.sin(angle)
        y = arc_radius * (1 - math.cos(angle)) - arc_radius * (1 - math.cos(bend / 2)) / 2
        taper = 1.0 - 0.45 * abs(2 * t - 1) ** 1.5
        r = radius * taper
        half_length = length / segments / 2
        rotation = axis_angle_quat((0, 0, 1), angle)
        parts.append(Part("capsule", (r, half_length), (x, y, r), rotation))  # every segment rests on the table
    return parts


def bowl(top_radius: float, bottom_radius: float, height: float, wall: float = 0.006, segments: int = 16) -> list[Part]:
    """An open bowl: a flat disc floor and a ring of thin slanted wall plates."""
    parts = [Part("cylinder", (bottom_radius + wall, wall / 2), (0.0, 0.0, wall / 2), X_TO_Z)]
    slant = math.atan2(top_radius - bottom_radius, height)
    wall_length = math.hypot(height, top_radius - bottom_radius)
    mid_radius = (top_radius + bottom_radius) / 2 + wall / 2
    chord = 2 * mid_radius * math.tan(math.pi / segments) * 1.08
    for i in range(segments):
        yaw = 2 * math.pi * i / segments
        tilt = axis_angle_quat((0, 1, 0), slant)  # lean the plate outwards, about its tangent axis
        rotation = quat_multiply(axis_angle_quat((0, 0, 1), yaw), tilt)
        position = (mid_radius * math.cos(yaw), mid_radius * math.sin(yaw), height / 2 + wall / 2)
        parts.append(Part("box", (wall / 2, chord / 2, wall_length / 2), position, rotation))
    return parts


def open_box(size: list[float], wall: float = 0.008) -> list[Part]:
    """An open-topped box of outer size (x, y, z) with thin walls (bins, crates, trays)."""
    x, y, z = size
    parts = [Part("box", (x / 2, y / 2, wall / 2), (0.0, 0.0, wall / 2))]
    for sign in (-1, 1):
        parts.append(Part("box", (wall / 2, y / 2, z / 2), (sign * (x - wall) / 2, 0.0, z / 2)))
        parts.append(Part("box", (x / 2 - wall, wall / 2, z / 2), (0.0, sign * (y - wall) / 2, z / 2)))
    return parts


GENERATORS: dict[str, Callable[..., list[Part]]] = {
    "open_box": open_box,
    "box": box,
    "cylinder": cylinder,
    "sphere": sphere,
    "arc_capsules": arc_capsules,
    "bowl": bowl,
}


def generate(generator: str, params: dict) -> list[Part]:
    """Run a named generator with the catalog's parameters."""
    if generator not in GENERATORS:
        raise UnknownNameError("procedural generator", generator, GENERATORS)
    return GENERATORS[generator](**params)
