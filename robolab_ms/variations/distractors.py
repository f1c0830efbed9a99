"""Distractors: new colours and surface textures for the objects a task does not name (LIBERO-Plus perturbs these).

A distractor is a scene object that no success condition or subtask of the task names, as an object or as a
reference. Its new colour is never one of the task objects' colours nor close to one (within SIMILAR_COLOUR in RGB:
dark red for red, gold or orange for yellow), so an instruction such as "the red mug" keeps pointing at one object.
The new look replaces the texture of every visual part: a generated texture of the drawn
kind in the drawn colour (`own` keeps the object's own kind, or tints a texture image of its own).
"""

from __future__ import annotations

from typing import Any

from robolab_ms.variations.base import Axis, Choice, Context, FieldValue, Names, Param, Range, VariationError, stream

TEXTURES = ("plastic", "wood", "metal", "ceramic", "rubber", "paper", "print")
SIMILAR_COLOUR = 0.5  # RGB distance under which a colour counts as a task object's colour


def _colours() -> list[str]:
    from robolab_ms.catalog import COLOR_NAMES

    return list(COLOR_NAMES)


def task_objects(task: Any) -> set[str]:
    """Every scene object the task's success conditions and subtasks name, as objects or references."""
    conditions = list(task.success) + [step for stage in task.subtasks for step in stage.steps]
    names = {name for condition in conditions for name in condition.objects}
    names |= {value for condition in conditions for value in condition.references.values() if isinstance(value, str)}
    names |= {name for stage in task.subtasks for name in stage.objects}
    return names & set(task.scene.object_names())


def distractors(context: Context, chosen: Names) -> list[str]:
    """The task's distractors (scene order), limited to `chosen`."""
    named = task_objects(context.task)
    others = [name for name in context.task.scene.object_names() if name not in named]
    if chosen.names is None:
        return others
    for name in chosen.names:
        if name not in others:
            raise VariationError(
                f"distractors.names: '{name}' is not a distractor of {context.task.name} "
                f"(its distractors: {', '.join(others) or 'none'})"
            )
    return [name for name in others if name in chosen.names]


class DistractorAxis(Axis):
    name = "distractors"
    summary = "colour and texture swaps of the objects the task does not name"
    params = (
        Param(
            "color",
            "choice",
            Choice(("own",)),
            Choice(("all",)),
            "catalog colour names; the task objects' colours are left out",
            options=_colours,
        ),
        Param("texture", "choice", Choice(("own",)), Choice(TEXTURES), "surface kinds", options=lambda: list(TEXTURES)),
        Param("names", "names", Names(None), Names(None), "which distractors (default: all)"),
    )
    shorthand = None

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        colours = ranges["color"]
        if colours.describe() != ["own"]:
            free = tuple(c for c in colours.options if c not in task_colours(context))
            colours = Choice(free or ("own",))
        fields: dict[str, FieldValue] = {}
        for name in distractors(context, ranges["names"]):
            fields[f"distractor_{name}_color"] = colours.draw(stream(seed, self.name, name, "color"))
            fields[f"distractor_{name}_texture"] = ranges["texture"].draw(stream(seed, self.name, name, "texture"))
        return fields

    def after_build(self, builder: Any, fields: dict[str, FieldValue], context: Context) -> None:
        for name, actor in builder.objects.items():
            if f"distractor_{name}_color" in fields:
                entry = context.catalog[_asset(context, name)]
                colour, texture = fields[f"distractor_{name}_color"], fields[f"distractor_{name}_texture"]
                restyle(actor, entry, str(colour), str(texture))


def task_colours(context: Context) -> set[str]:
    """Catalog colour names a distractor must not take: the task objects' colours and those close to them."""
    from robolab_ms.catalog import COLOR_NAMES

    taken = {c for name in task_objects(context.task) for c in context.catalog[_asset(context, name)].colors}
    return {
        name
        for name, rgb in COLOR_NAMES.items()
        if any(
            sum((a - b) ** 2 for a, b in zip(rgb, COLOR_NAMES[other])) ** 0.5 < SIMILAR_COLOUR
            for other in taken
            if other in COLOR_NAMES
        )
    }


def _asset(context: Context, name: str) -> str:
    return next(p.asset for p in context.task.scene.objects if p.name == name)


def restyle(actor: Any, entry: Any, colour: str, texture: str) -> None:
    """Give every visual part of a built actor a new look: colour `colour` (a catalog colour name, or `own`) as a
    generated texture of kind `texture` (or `own`: the object's own kind; an object textured by an image keeps its
    image, tinted)."""
    import sapien

    from robolab_ms.catalog import COLOR_NAMES
    from robolab_ms.catalog.appearance import SURFACES, part_look, render_texture

    own = part_look(entry, 0)
    rgb = own.rgb if colour == "own" else tuple(COLOR_NAMES[colour])
    image_textured = bool(entry.source.get("textured"))
    tint_only = texture == "own" and image_textured
    kind = own.kind if texture == "own" else texture
    roughness, metallic = SURFACES[kind]
    new_texture = None if tint_only else render_texture(kind, tuple(round(float(c), 3) for c in rgb))
    for entity in actor._objs:
        component = entity.find_component_by_type(sapien.render.RenderBodyComponent)
        for shape in component.render_shapes:
            for part in shape.parts:
                material = part.material
                if tint_only:
                    material.base_color = [*rgb, 1.0]
                    continue
                material.base_color = [1.0, 1.0, 1.0, 1.0]
                material.base_color_texture = new_texture
                material.roughness, material.metallic = roughness, metallic
