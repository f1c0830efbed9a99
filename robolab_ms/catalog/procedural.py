"""Procedural object generators: each turns a few parameters into primitive parts.

A part is one primitive (box, sphere, capsule, cylinder) with its pose in the object frame and a colour. The same
parts are used for rendering and, exactly, for collision. The object frame has z up and its origin at the centre of
the bottom face, so an object rests on a surface when its origin is on that surface.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from robolab_ms.errors import UnknownNameError

Quat = tuple[float, float, float, float]  # (w, x, y, z), SAPIEN's order
IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Part:
    """One primitive. `size` is half-extents (box), (radius,) (sphere), (radius, half_length) (capsule and
    cylinder, axis along the part's local x, as in SAPIEN). `tint` picks the object's colour: 0 the first of its
    colours, 1 the second, and so on (the last one when it has fewer)."""

    shape: str
    size: tuple[float, ...]
    position: tuple[float, float, float]
    rotation: Quat = IDENTITY
    tint: int = 0

    def volume(self) -> float:
        if self.shape == "box":
            return 8.0 * math.prod(self.size)
        if self.shape == "sphere":
            return 4.0 / 3.0 * math.pi * self.size[0] ** 3
        radius, half_length = self.size
        if self.shape == "cylinder":
            return math.pi * radius**2 * 2 * half_length
        return math.pi * radius**2 * 2 * half_length + 4.0 / 3.0 * math.pi * radius**3  # capsule

    def half_extent(self) -> np.ndarray:
        """Exact half size of the part's axis-aligned bounding box in the object frame (x, y, z)."""
        rotation = quat_to_matrix(self.rotation)
        if self.shape == "box":
            return np.abs(rotation) @ np.asarray(self.size)
        if self.shape == "sphere":
            return np.full(3, self.size[0])
        radius, half_length = self.size
        axis = np.abs(rotation[:, 0])
        if self.shape == "capsule":
            return axis * half_length + radius
        return axis * half_length + radius * np.sqrt(np.clip(1 - axis**2, 0, 1))

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


def yaw_quat(yaw: float) -> Quat:
    """A turn by `yaw` (rad) about the z axis."""
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def quat_multiply(a: Quat, b: Quat) -> Quat:
    """The rotation b then a, as one quaternion (w, x, y, z)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    )


X_TO_Z: Quat = axis_angle_quat((0, 1, 0), -math.pi / 2)  # turns a part's x axis to the object's z axis
PARAM_CHOICES = {  # the values a generator's text parameter may take
    "handle": ("none", "side", "long", "pair"),
    "head": ("spoon", "fork", "ladle", "spatula", "knife"),
}

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


def _upright_cylinder(radius: float, height: float, bottom: float, tint: int = 0) -> Part:
    return Part("cylinder", (radius, height / 2), (0.0, 0.0, bottom + height / 2), X_TO_Z, tint)


def bottle(
    radius: float,
    height: float,
    neck_radius: float,
    neck_height: float,
    cap_height: float = 0.015,
    square: bool = False,
) -> list[Part]:
    """An upright bottle: a body (round, or square when `square`), a neck and a cap in the second colour."""
    body_height = height - neck_height - cap_height
    if square:
        parts = [Part("box", (radius, radius, body_height / 2), (0.0, 0.0, body_height / 2))]
    else:
        parts = [_upright_cylinder(radius, body_height, 0.0)]
    parts.append(_upright_cylinder(neck_radius, neck_height, body_height))
    parts.append(_upright_cylinder(neck_radius * 1.15, cap_height, body_height + neck_height, tint=1))
    return parts


def can(radius: float, height: float, rim: float = 0.004) -> list[Part]:
    """An upright can: a body in the first colour with a thin lid and base in the second."""
    body = height - 2 * rim
    return [
        _upright_cylinder(radius * 0.97, rim, 0.0, tint=1),
        _upright_cylinder(radius, body, rim),
        _upright_cylinder(radius * 0.97, rim, rim + body, tint=1),
    ]


def carton(size: list[float], cap_radius: float = 0.0) -> list[Part]:
    """A box-shaped carton or grocery box of full size (x, y, z), optionally with a round cap on top."""
    parts = box(size)
    if cap_radius > 0:
        parts.append(_upright_cylinder(cap_radius, 0.012, size[2], tint=1))
    return parts


def ellipsoid_fruit(radius: float, length: float, stem_length: float = 0.0) -> list[Part]:
    """An elongated fruit lying on its side (lemon, lime, avocado, potato): a capsule along x."""
    parts = [Part("capsule", (radius, length / 2), (0.0, 0.0, radius))]
    if stem_length > 0:
        parts.append(
            Part(
                "capsule",
                (max(radius * 0.08, 0.002), stem_length / 2),
                (length / 2 + radius + stem_length / 2, 0.0, radius),
                IDENTITY,
                1,
            )
        )
    return parts


def round_fruit(radius: float, stem_length: float = 0.0, flat: float = 0.0) -> list[Part]:
    """A round fruit or vegetable resting on a small flat base, with an optional stem in the second colour.

    `flat` is the height of the base disc that keeps it from rolling (a fraction of the radius)."""
    base_height = max(flat * radius, 0.002)
    parts = [_upright_cylinder(radius * 0.45, base_height, 0.0), Part("sphere", (radius,), (0.0, 0.0, radius))]
    if stem_length > 0:
        stem_radius = max(radius * 0.07, 0.002)
        parts.append(Part("capsule", (stem_radius, stem_length / 2), (0.0, 0.0, 2 * radius), X_TO_Z, 1))
    return parts


def cup(
    top_radius: float,
    bottom_radius: float,
    height: float,
    wall: float = 0.005,
    handle: str = "none",
    handle_length: float = 0.0,
    segments: int = 16,
) -> list[Part]:
    """An open vessel (mug, measuring cup, pitcher, pot, pail, jug) with an optional handle in the second colour.

    `handle`: none; side (a mug's loop); long (a straight grip, e.g. a measuring cup or pan); pair (two side grips,
    a pot)."""
    parts = bowl(top_radius, bottom_radius, height, wall, segments)
    grip = max(0.006, wall * 1.5)
    if handle == "side":
        reach = max(0.025, handle_length)
        x0 = top_radius + wall
        parts += [
            Part("box", (reach / 2, grip / 2, grip / 2), (x0 + reach / 2, 0.0, height * 0.8), IDENTITY, 1),
            Part("box", (reach / 2, grip / 2, grip / 2), (x0 + reach / 2, 0.0, height * 0.25), IDENTITY, 1),
            Part("box", (grip / 2, grip / 2, height * 0.3), (x0 + reach - grip / 2, 0.0, height * 0.525), IDENTITY, 1),
        ]
    elif handle == "long":
        reach = max(0.04, handle_length)
        parts.append(
            Part("box", (reach / 2, grip, grip / 2), (top_radius + reach / 2, 0.0, height - grip), IDENTITY, 1)
        )
    elif handle == "pair":
        for sign in (-1, 1):
            parts.append(
                Part("box", (0.015, 0.025, grip / 2), (sign * (top_radius + 0.012), 0.0, height - grip), IDENTITY, 1)
            )
    elif handle != "none":
        raise TypeError(f"handle must be one of {', '.join(PARAM_CHOICES['handle'])}, got {handle!r}")
    return parts


def shelf(size: list[float], levels: int = 2, board: float = 0.015) -> list[Part]:
    """An open shelf unit of outer size (x deep, y wide, z tall): two side panels, a back and `levels` boards."""
    x, y, z = size
    parts = []
    for sign in (-1, 1):
        parts.append(Part("box", (x / 2, board / 2, z / 2), (0.0, sign * (y - board) / 2, z / 2)))
    parts.append(Part("box", (board / 2, y / 2 - board, z / 2), (-(x - board) / 2, 0.0, z / 2)))
    for level in range(levels + 1):
        height = board / 2 + level * (z - board) / levels
        parts.append(Part("box", (x / 2, y / 2 - board, board / 2), (0.0, 0.0, height), IDENTITY, 1))
    return parts


def rack(
    size: list[float], levels: int = 3, board: float = 0.015, post: float = 0.02, bottom: float = 0.0
) -> list[Part]:
    """An open rack of outer size (x deep, y wide, z tall), open on every side: four corner posts and `levels`
    boards in the second colour, evenly spaced from the lowest (its underside `bottom` above the ground) to the
    highest (flush with the posts' tops). A wire shelf is such a rack with thin solid boards."""
    x, y, z = size
    parts = [
        Part("box", (post / 2, post / 2, z / 2), (sx * (x - post) / 2, sy * (y - post) / 2, z / 2))
        for sx in (-1, 1)
        for sy in (-1, 1)
    ]
    spacing = (z - board - bottom) / (levels - 1) if levels > 1 else 0.0
    for level in range(levels):
        underside = z - board if levels == 1 else bottom + level * spacing
        parts.append(Part("box", (x / 2, y / 2, board / 2), (0.0, 0.0, underside + board / 2), IDENTITY, 1))
    return parts


def utensil(
    length: float, head: str, head_size: float, handle_width: float = 0.012, thickness: float = 0.006
) -> list[Part]:
    """A utensil lying flat: a handle along x and a head (spoon, fork, ladle, spatula, knife) in the second colour."""
    head_length = head_size * (2.2 if head in ("spoon", "knife") else 2.0)
    handle_length = length - head_length
    parts = [Part("box", (handle_length / 2, handle_width / 2, thickness / 2), (-head_length / 2, 0.0, thickness / 2))]
    centre = handle_length / 2
    if head in ("spoon", "ladle"):
        depth = thickness * (3.0 if head == "ladle" else 1.2)
        parts.append(Part("cylinder", (head_size, depth / 2), (centre, 0.0, depth / 2), X_TO_Z, 1))
    elif head == "fork":
        parts.append(
            Part(
                "box",
                (head_length * 0.15, head_size / 2, thickness / 2),
                (centre - head_length * 0.35, 0.0, thickness / 2),
                IDENTITY,
                1,
            )
        )
        for tine in range(4):
            y = (tine - 1.5) * head_size / 4
            parts.append(
                Part(
                    "box",
                    (head_length * 0.35, head_size / 12, thickness / 2),
                    (centre + head_length * 0.15, y, thickness / 2),
                    IDENTITY,
                    1,
                )
            )
    elif head in ("spatula", "knife"):
        width = head_size if head == "spatula" else head_size * 0.5
        parts.append(
            Part("box", (head_length / 2, width / 2, thickness / 4), (centre, 0.0, thickness / 4), IDENTITY, 1)
        )
    else:
        raise TypeError(f"head must be one of {', '.join(PARAM_CHOICES['head'])}, got {head!r}")
    return parts


def hammer(length: float, head_size: list[float], handle_width: float = 0.025) -> list[Part]:
    """A hammer lying on its side: a handle along x and a head block (second colour) at +x."""
    hx, hy, hz = head_size
    handle_length = length - hx
    parts = [Part("box", (handle_length / 2, handle_width / 2, handle_width / 2), (-hx / 2, 0.0, handle_width / 2))]
    parts.append(Part("box", (hx / 2, hy / 2, hz / 2), (handle_length / 2, 0.0, hz / 2), IDENTITY, 1))
    return parts


def drill(height: float = 0.22, length: float = 0.2) -> list[Part]:
    """A cordless drill standing on its battery: battery block, grip, motor body and chuck (second colour)."""
    battery = (0.1, 0.075, 0.05)
    body_radius = 0.03
    grip_height = height - battery[2] - 2 * body_radius
    parts = [
        Part("box", tuple(b / 2 for b in battery), (0.0, 0.0, battery[2] / 2), IDENTITY, 1),
        Part("box", (0.02, 0.016, grip_height / 2), (0.0, 0.0, battery[2] + grip_height / 2)),
        Part("cylinder", (body_radius, (length - 0.05) / 2), (length / 2 - 0.08, 0.0, height - body_radius)),
        Part("cylinder", (0.013, 0.025), (length - 0.055, 0.0, height - body_radius), IDENTITY, 1),
    ]
    return parts


def _limb(radius: float, start: tuple[float, float, float], end: tuple[float, float, float], tint: int = 0) -> Part:
    """A capsule from `start` to `end` (its two cap centres)."""
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    axis = b - a
    half_length = float(np.linalg.norm(axis)) / 2
    x = np.array([1.0, 0.0, 0.0])
    turn = np.cross(x, axis)
    angle = math.atan2(float(np.linalg.norm(turn)), float(x @ axis))
    rotation = axis_angle_quat(tuple(turn), angle) if np.linalg.norm(turn) > 1e-9 else IDENTITY
    return Part("capsule", (radius, half_length), tuple(float(v) for v in (a + b) / 2), rotation, tint)


def lizard(length: float = 0.24, width: float = 0.14, height: float = 0.135, body_radius: float = 0.026) -> list[Part]:
    """A lizard figurine standing on four splayed legs, head raised at +x, its tail down on the table at -x; the
    eyes take the second colour. The body is a slender capsule (`body_radius`), so it is narrower than the legs'
    span (`width`)."""
    head_radius, tail_radius, leg_radius = 0.8 * body_radius, 0.4 * body_radius, 0.42 * body_radius
    head_tip = 0.42 * length  # the head's front ahead of the body's middle; the tail ends `length` behind it
    hip, shoulder = (-0.045, 0.0, 0.045), (0.05, 0.0, 0.06)
    head_end = (head_tip - head_radius, 0.0, height - head_radius)
    head_start = (head_end[0] - 0.045, 0.0, head_end[2] - 0.035)
    tail_mid = (-0.095, 0.0, 0.022)
    tail_end = (head_tip - length + tail_radius * 0.8, 0.025, tail_radius * 0.8)
    parts = [
        _limb(body_radius, hip, shoulder),
        _limb(0.85 * body_radius, (shoulder[0] - 0.005, 0.0, shoulder[2]), head_start),  # neck
        _limb(head_radius, head_start, head_end),
        _limb(0.6 * body_radius, (hip[0] - 0.01, 0.0, hip[2] - 0.005), tail_mid),
        _limb(tail_radius * 0.8, tail_mid, tail_end),
    ]
    foot = width / 2 - leg_radius
    for x, z, reach in ((hip[0] + 0.01, hip[2], -0.012), (shoulder[0] - 0.01, shoulder[2], 0.012)):
        for side in (-1, 1):
            parts.append(_limb(leg_radius, (x, side * 0.5 * body_radius, z), (x + reach, side * foot, leg_radius)))
    for side in (-1, 1):  # the eyes, on the sides of the head
        eye = (head_end[0] - 0.004, side * head_radius * 0.8, head_end[2] + 0.004)
        parts.append(Part("sphere", (0.005,), eye, IDENTITY, 1))
    points = np.concatenate([part.surface_points() for part in parts])
    shift = -(points[:, 0].min() + points[:, 0].max()) / 2  # the origin under the middle of the figurine's length
    return [replace(part, position=(part.position[0] + shift, *part.position[1:])) for part in parts]


def clamp(length: float = 0.16, jaw: float = 0.04) -> list[Part]:
    """A spring clamp lying flat: two handles in a narrow V and two jaw pads (second colour)."""
    thickness = 0.02
    parts = []
    for sign in (-1, 1):
        rotation = axis_angle_quat((0, 0, 1), sign * 0.12)
        parts.append(
            Part("box", (length * 0.35, 0.008, thickness / 2), (-length * 0.15, sign * 0.02, thickness / 2), rotation)
        )
        parts.append(
            Part("box", (jaw / 2, 0.01, thickness / 2), (length * 0.3, sign * 0.008, thickness / 2), IDENTITY, 1)
        )
    return parts


def stick(length: float, radius: float, cap_length: float = 0.0, cap_radius: float | None = None) -> list[Part]:
    """A pen, marker or similar rod lying on the table along x, with an optional cap (or handle) in the second
    colour, `cap_radius` thick (default a tenth wider than the rod); rod and cap both rest on the table."""
    body = length - cap_length
    parts = [Part("cylinder", (radius, body / 2), (-cap_length / 2, 0.0, radius))]
    if cap_length > 0:
        cap = radius * 1.1 if cap_radius is None else cap_radius
        parts.append(Part("cylinder", (cap, cap_length / 2), (body / 2, 0.0, cap), IDENTITY, 1))
    return parts


def puzzle_cube(size: float = 0.057) -> list[Part]:
    """A Rubik's-style cube: a dark core with a coloured tile on each face (colours 2..7 of the object)."""
    half = size / 2
    tile = 0.0015
    parts = [Part("box", (half - tile, half - tile, half - tile), (0.0, 0.0, half))]
    faces = [((0, 0, 1), 1), ((0, 0, -1), 2), ((1, 0, 0), 3), ((-1, 0, 0), 4), ((0, 1, 0), 5), ((0, -1, 0), 6)]
    for (nx, ny, nz), tint in faces:
        extent = [half * 0.92 if n == 0 else tile / 2 for n in (nx, ny, nz)]
        position = (nx * (half - tile / 2), ny * (half - tile / 2), half + nz * (half - tile / 2))
        parts.append(Part("box", tuple(extent), position, IDENTITY, tint))
    return parts


def flat_device(size: list[float], screen: bool = True) -> list[Part]:
    """A flat device lying on the table (smartphone, remote, keyboard, book): a body and an optional top panel
    (screen or key field) in the second colour."""
    parts = box(size)
    if screen:
        x, y, z = size
        parts.append(Part("box", (x * 0.42, y * 0.42, 0.0008), (0.0, 0.0, z + 0.0008), IDENTITY, 1))
    return parts


GENERATORS: dict[str, Callable[..., list[Part]]] = {
    "open_box": open_box,
    "box": box,
    "cylinder": cylinder,
    "sphere": sphere,
    "arc_capsules": arc_capsules,
    "bowl": bowl,
    "bottle": bottle,
    "can": can,
    "carton": carton,
    "ellipsoid_fruit": ellipsoid_fruit,
    "round_fruit": round_fruit,
    "cup": cup,
    "shelf": shelf,
    "rack": rack,
    "utensil": utensil,
    "hammer": hammer,
    "drill": drill,
    "lizard": lizard,
    "clamp": clamp,
    "stick": stick,
    "puzzle_cube": puzzle_cube,
    "flat_device": flat_device,
}


def procedural_interior(generator: str, params: dict) -> list[float] | None:
    """Inner size (x, y, z) of a procedural container, or None for shapes that hold nothing."""
    if generator in ("bowl", "cup"):
        wall = params.get("wall", 0.006 if generator == "bowl" else 0.005)
        diameter = 2 * (params["top_radius"] - wall)
        return [diameter, diameter, params["height"] - wall]
    if generator == "open_box":
        wall = params.get("wall", 0.008)
        x, y, z = params["size"]
        return [x - 2 * wall, y - 2 * wall, z - wall]
    return None


def generate(generator: str, params: dict) -> list[Part]:
    """Run a named generator with the catalog's parameters."""
    if generator not in GENERATORS:
        raise UnknownNameError("procedural generator", generator, GENERATORS)
    return GENERATORS[generator](**params)
