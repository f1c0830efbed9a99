"""Background and table: which HDR map surrounds and lights the room (and its floor), and the table top's material."""

from __future__ import annotations

from typing import Any

from robolab_ms.variations.base import Axis, Choice, Context, FieldValue, Param, Range


def _backgrounds() -> list[str]:
    from robolab_ms.scene.backgrounds import load_looks

    return list(load_looks().backgrounds)


def _table_materials() -> list[str]:
    from robolab_ms.scene.backgrounds import load_looks

    return list(load_looks().table_materials)


class BackgroundAxis(Axis):
    name = "background"
    summary = "the HDR map seen behind the table and lighting the scene (with its room's floor)"
    params = (
        Param(
            "name",
            "choice",
            Choice(("scene",)),
            Choice(("all",)),
            "background names (assets/backgrounds.yaml)",
            options=_backgrounds,
        ),
    )
    shorthand = "name"

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        if ranges["name"].describe() == ["scene"]:
            from robolab_ms.scene.backgrounds import load_looks

            return {"background": context.task.scene.background or load_looks().default_background}
        return {"background": self.draw(ranges, seed, "name")}

    def configure_builder(self, builder: Any, fields: dict[str, FieldValue]) -> None:
        from robolab_ms.scene.backgrounds import load_looks

        builder.background = load_looks().background(str(fields["background"]))


class TableAxis(Axis):
    name = "table"
    summary = "the table top's material and texture"
    params = (
        Param(
            "material",
            "choice",
            Choice(("scene",)),
            Choice(("all",)),
            "table materials (assets/backgrounds.yaml: light_wood is RoboLab's oak, wood_planks its walnut planks, "
            "bamboo and black_matte its other two)",
            options=_table_materials,
        ),
    )
    shorthand = "material"

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        if ranges["material"].describe() == ["scene"]:
            return {"table_material": scene_table_material(context)}
        return {"table_material": self.draw(ranges, seed, "material")}

    def configure_builder(self, builder: Any, fields: dict[str, FieldValue]) -> None:
        if fields["table_material"] != "scene_color":
            builder.table_material = str(fields["table_material"])


def scene_table_material(context: Context) -> str:
    """The scene's own table material (`scene_color` for a plain coloured table)."""
    from robolab_ms.scene.room import table_material

    return table_material(context.task.scene) or "scene_color"
