"""Lighting: the key light's intensity, colour and direction, the environment map's light, and an ambient level.

`intensity` scales the key light (RoboLab's main light; its conditions run from very dim, 1 %, to very bright) and
`environment` the light of the environment map (RoboLab's dome light, low and high). `color` tints the key light
(RoboLab's strong red, green and blue lights are the pure colours, brightened). `direction` says where the key
light shines from: the room's own key light (`key`), or from the front (the table's far side), behind (the robot's
side), left, right or straight above, stronger, with hard shadows. `ambient` adds a uniform light everywhere.

Each environment level needs its own filtered environment map, which SAPIEN makes at its first use in a process
(about 2.5 s on a CPU renderer, once per background and level): drawn environment levels therefore take one of the
few values of ENVIRONMENT_LEVELS within the range; the key light, ambient, colour and direction cost nothing.
"""

from __future__ import annotations

import math
from typing import Any

from robolab_ms.variations.base import Axis, Choice, Context, FieldValue, Param, Range, Uniform

# key light tints (multiplied into the room's warm white); the pure colours are brightened so they dominate
LIGHT_COLORS: dict[str, tuple[float, float, float]] = {
    "white": (1.0, 1.0, 1.0),
    "warm": (1.15, 0.9, 0.62),
    "cool": (0.75, 0.9, 1.2),
    "red": (3.0, 0.0, 0.0),
    "green": (0.0, 3.0, 0.0),
    "blue": (0.0, 0.0, 3.0),
}
# where the key light comes from: azimuth about z from +x (toward +y), elevation above the table, degrees;
# `key` is the room's own light
LIGHT_DIRECTIONS: dict[str, tuple[float, float] | None] = {
    "key": None,
    "front": (0.0, 40.0),
    "behind": (180.0, 40.0),
    "left": (90.0, 40.0),
    "right": (-90.0, 40.0),
    "top": (0.0, 90.0),
}
DIRECTIONAL_KEY_BOOST = 2.0  # a directional condition's key light is this much stronger, for hard shadows
MIN_INTENSITY, MAX_INTENSITY = 0.005, 10.0
ENVIRONMENT_LEVELS = (0.1, 0.25, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0)  # what a drawn environment level snaps to


def direction_vector(name: str) -> tuple[float, float, float]:
    """The direction the key light shines to (unit vector) for a named direction."""
    from robolab_ms.scene.room import KEY_LIGHT_DIRECTION

    angles = LIGHT_DIRECTIONS[name]
    if angles is None:
        x, y, z = KEY_LIGHT_DIRECTION
        norm = math.sqrt(x * x + y * y + z * z)
        return (x / norm, y / norm, z / norm)
    azimuth, elevation = (math.radians(a) for a in angles)
    source = (math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth), math.sin(elevation))
    return tuple(-c + 0.0 for c in source)


def environment_level(value: float, low: float, high: float) -> float:
    """A drawn environment level snapped to the nearest (log scale) of ENVIRONMENT_LEVELS within [low, high];
    a fixed value (low == high) or a range holding no level keeps two significant digits."""
    levels = [level for level in ENVIRONMENT_LEVELS if low <= level <= high]
    if low == high or not levels:
        return float(f"{value:.2g}")
    return min(levels, key=lambda level: abs(math.log(level / value)))


class LightingAxis(Axis):
    name = "lighting"
    summary = "key light intensity, colour and direction, environment (dome) light, ambient light"
    params = (
        Param(
            "intensity",
            "value",
            Uniform(1.0, 1.0),
            Uniform(0.05, 3.0, log=True),
            "factor on the key light; drawn log-uniformly",
            MIN_INTENSITY,
            MAX_INTENSITY,
            log=True,
        ),
        Param(
            "environment",
            "value",
            Uniform(1.0, 1.0),
            Uniform(0.25, 2.0, log=True),
            "factor on the environment map's light; drawn levels snap to " + "/".join(map(str, ENVIRONMENT_LEVELS)),
            MIN_INTENSITY,
            MAX_INTENSITY,
            log=True,
        ),
        Param(
            "color",
            "choice",
            Choice(("white",)),
            Choice(tuple(LIGHT_COLORS)),
            "key light colour",
            options=lambda: list(LIGHT_COLORS),
        ),
        Param(
            "direction",
            "choice",
            Choice(("key",)),
            Choice(tuple(LIGHT_DIRECTIONS)),
            "where the key light shines from",
            options=lambda: list(LIGHT_DIRECTIONS),
        ),
        Param("ambient", "value", Uniform(0.0, 0.0), Uniform(0.0, 0.08), "ambient light level added", 0.0, 2.0),
    )
    shorthand = None
    presets = {
        "dim": {"intensity": 0.01, "environment": 0.1},
        "bright": {"intensity": 3.0, "environment": 2.0},
        "dome_low": {"environment": 0.25},
        "dome_high": {"environment": 2.0},
        "directional": {"direction": "front/behind/left/right/top"},
        "red": {"color": "red"},
        "green": {"color": "green"},
        "blue": {"color": "blue"},
        **{name: {"direction": name} for name in LIGHT_DIRECTIONS if name != "key"},
    }

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        environment = ranges["environment"]
        return {
            "light_intensity": round(self.draw(ranges, seed, "intensity"), 4),
            "light_environment": environment_level(
                self.draw(ranges, seed, "environment"), environment.low, environment.high
            ),
            "light_color": self.draw(ranges, seed, "color"),
            "light_direction": self.draw(ranges, seed, "direction"),
            "light_ambient": round(self.draw(ranges, seed, "ambient"), 4),
        }

    def configure_builder(self, builder: Any, fields: dict[str, FieldValue]) -> None:
        from robolab_ms.scene.room import AMBIENT_LIGHT, KEY_LIGHT_COLOR, LightSetup

        intensity = float(fields["light_intensity"])
        tint = LIGHT_COLORS[str(fields["light_color"])]
        direction = str(fields["light_direction"])
        boost = 1.0 if direction == "key" else DIRECTIONAL_KEY_BOOST
        key = tuple(c * t * intensity * boost for c, t in zip(KEY_LIGHT_COLOR, tint))
        ambient = tuple(c + float(fields["light_ambient"]) for c in AMBIENT_LIGHT)
        builder.light = LightSetup(direction_vector(direction), key, ambient, float(fields["light_environment"]))
