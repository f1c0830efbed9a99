"""The room's look as plain data, shared by the scene builder and the variations: the room's light (`LightSetup`,
whose defaults are the room's own key light) and which material a scene's table top shows (`table_material`)."""

from __future__ import annotations

from dataclasses import dataclass

from robolab_ms.catalog import COLOR_NAMES
from robolab_ms.scene.spec import DEFAULT_TABLE_COLOR, SceneSpec

AMBIENT_LIGHT = (0.0, 0.0, 0.0)
KEY_LIGHT_DIRECTION = (-0.45, -0.25, -1.0)  # from above, in front of the robot and to its left
KEY_LIGHT_COLOR = (0.56, 0.6, 0.66)  # slightly cool: with the warm room the white balance comes out near neutral


@dataclass(frozen=True)
class LightSetup:
    """The room's light as built: the key light's direction (where it shines to) and colour, the ambient light and
    the factor on the environment map's light. The defaults are the room's own; robolab_ms.variations changes them."""

    key_direction: tuple[float, float, float] = KEY_LIGHT_DIRECTION
    key_color: tuple[float, float, float] = KEY_LIGHT_COLOR
    ambient: tuple[float, float, float] = AMBIENT_LIGHT
    environment: float = 1.0


def is_default_color(rgba) -> bool:
    """Whether a table colour is the scene files' default, DEFAULT_TABLE_COLOR (to 3 decimals)."""
    return tuple(round(c, 3) for c in rgba[:3]) == tuple(round(c, 3) for c in COLOR_NAMES[DEFAULT_TABLE_COLOR])


def table_material(spec: SceneSpec) -> str | None:
    """The table material a scene's table top shows: the scene's own, the default wood for a brown table, or None
    for a table of another plain colour."""
    from robolab_ms.scene.backgrounds import load_looks

    if spec.table_material:
        return spec.table_material
    return load_looks().default_table_material if is_default_color(spec.table_rgba) else None
