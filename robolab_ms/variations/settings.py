"""Variation settings (`--vary` text, a dict, or a Variations) and the parameters drawn for one episode."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from robolab_ms.errors import did_you_mean
from robolab_ms.variations.background import BackgroundAxis, TableAxis
from robolab_ms.variations.base import Axis, Choice, Context, FieldValue, Range, VariationError
from robolab_ms.variations.camera import CameraAxis
from robolab_ms.variations.distractors import DistractorAxis
from robolab_ms.variations.lighting import LightingAxis
from robolab_ms.variations.noise import NoiseAxis
from robolab_ms.variations.objects import ObjectPoseAxis
from robolab_ms.variations.robot import RobotAxis

AXES: dict[str, Axis] = {
    axis.name: axis
    for axis in (
        LightingAxis(),
        BackgroundAxis(),
        TableAxis(),
        CameraAxis(),
        ObjectPoseAxis(),
        RobotAxis(),
        NoiseAxis(),
        DistractorAxis(),
    )
}


@dataclass(frozen=True)
class _Item:
    axis: str
    param: str | None
    value: Any  # None for a bare axis
    text: str


def _items_from_text(text: str) -> list[_Item]:
    items = []
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        key, _, value = part.partition("=")
        key, value = key.strip(), value.strip()
        if "=" in part and not value:
            raise VariationError(f"--vary '{part}': no value after '='; e.g. objects=0.2 or lighting.intensity=0.5:2")
        axis, _, param = key.partition(".")
        items.append(_Item(axis, param or None, value if "=" in part else None, part))
    return items


def _value_text(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        separator = "/" if all(isinstance(v, str) for v in value) else ":"
        return separator.join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def _items_from_dict(value: dict) -> list[_Item]:
    items = []
    for axis, setting in value.items():
        if setting is True or setting is None:
            items.append(_Item(axis, None, None, axis))
        elif setting is False:
            continue
        elif isinstance(setting, dict):
            for param, param_value in setting.items():
                items.append(_Item(axis, param, param_value, f"{axis}.{param}={_value_text(param_value)}"))
        else:
            items.append(_Item(axis, None, setting, f"{axis}={_value_text(setting)}"))
    return items


def _axis(name: str, where: str) -> Axis:
    if name not in AXES:
        raise VariationError(f"--vary '{where}': unknown axis '{name}'. {did_you_mean(name, AXES)}")
    return AXES[name]


def _resolve(axis: Axis, items: list[_Item]) -> dict[str, Range]:
    """Every parameter's range: the defaults when the axis is given bare, else the nominal values, then the items."""
    bare = any(item.param is None and item.value is None for item in items)
    ranges = {param.name: param.default if bare else param.nominal for param in axis.params}
    for item in items:
        if item.value is None and item.param is None:
            continue
        if item.param is not None:
            where = f"--vary '{item.text}'"
            ranges[item.param] = axis.param(item.param, where).parse(item.value, where)
            continue
        if isinstance(item.value, str) and item.value in axis.presets:
            for name, value in axis.presets[item.value].items():
                ranges[name] = axis.param(name, item.text).parse(value, f"--vary '{item.text}'")
            continue
        if axis.shorthand is None:
            presets = ", ".join(axis.presets) or "none"
            params = ", ".join(p.name for p in axis.params)
            raise VariationError(
                f"--vary '{item.text}': {axis.name} takes a condition ({presets}) or parameters "
                f"as {axis.name}.PARAM=VALUE ({params})"
            )
        ranges[axis.shorthand] = axis.param(axis.shorthand, item.text).parse(item.value, f"--vary '{item.text}'")
    for param in axis.params:  # `all` of a choice: every option known now
        value = ranges[param.name]
        if isinstance(value, Choice) and value.options == ("all",):
            ranges[param.name] = Choice(tuple(param.options()))
    return ranges


@dataclass(frozen=True)
class Variations:
    """Which axes vary and over which ranges: axis -> parameter -> range. `text` is the settings as given (the
    `--vary` text), recorded with every episode. Empty: nothing varies (the scenes as they are)."""

    axes: dict[str, dict[str, Range]] = field(default_factory=dict)
    text: str = ""

    @classmethod
    def create(cls, value: Variations | str | dict | Iterable[str] | None) -> Variations:
        """From `--vary` text (`lighting,objects=0.2,camera.wrist_rot=0.1`), several such texts, a dict
        ({"lighting": True, "objects": 0.2, "camera": {"wrist_rot": 0.1}}), a Variations, or None (nothing varies)."""
        if value is None:
            return cls()
        if isinstance(value, Variations):
            return value
        if isinstance(value, str):
            items = _items_from_text(value)
        elif isinstance(value, dict):
            items = _items_from_dict(value)
        elif isinstance(value, Iterable):
            items = [item for text in value for item in _items_from_text(str(text))]
        else:
            raise VariationError(f"variations must be text such as 'lighting,objects=0.2' or a dict, got {value!r}")
        by_axis: dict[str, list[_Item]] = {}
        for item in items:
            by_axis.setdefault(_axis(item.axis, item.text).name, []).append(item)
        axes = {name: _resolve(AXES[name], by_axis[name]) for name in AXES if name in by_axis}
        return cls(axes, ",".join(item.text for item in items))

    def __bool__(self) -> bool:
        return bool(self.axes)

    def __str__(self) -> str:
        return self.text

    def combined(self, other: Variations | str | dict | None) -> Variations:
        """These settings followed by `other`'s (a later setting of the same parameter wins)."""
        other = Variations.create(other)
        text = ",".join(t for t in (self.text, other.text) if t)
        return Variations.create(text)

    def ranges(self) -> dict[str, dict[str, Any]]:
        """The ranges as plain values (for the run manifest): [low, high], [names], or `all`."""
        return {axis: {name: value.describe() for name, value in params.items()} for axis, params in self.axes.items()}

    def draw(self, seed: int, context: Context) -> EpisodeVariation:
        """The parameters of the episode `seed`: the same seed always draws the same values."""
        fields: dict[str, FieldValue] = {}
        for name, ranges in self.axes.items():
            fields.update(AXES[name].sample(ranges, seed, context))
        return EpisodeVariation(self, int(seed), context, fields)


@dataclass
class EpisodeVariation:
    """One episode's drawn parameters (`fields`, flat and typed, recorded with the episode) and the hooks the
    environment calls to apply them."""

    variations: Variations
    seed: int
    context: Context
    fields: dict[str, FieldValue]

    def _axes(self) -> list[Axis]:
        return [AXES[name] for name in self.variations.axes]

    def configure_builder(self, builder: Any) -> None:
        for axis in self._axes():
            axis.configure_builder(builder, self.fields)

    def after_build(self, builder: Any) -> None:
        """The built actors' looks; nothing in a scene that cannot render (the fields are drawn and recorded all
        the same)."""
        from robolab_ms.catalog.appearance import scene_renders

        if not scene_renders(builder.scene):
            return
        for axis in self._axes():
            axis.after_build(builder, self.fields, self.context)

    def camera_configs(self, configs: list) -> list:
        for axis in self._axes():
            configs = axis.camera_configs(configs, self.fields)
        return configs

    def initialize(self, env: Any, env_idx: Any) -> None:
        for axis in self._axes():
            axis.initialize(env, env_idx, self.variations.axes[axis.name], self.fields)

    def sensor_effects(self, effects: Any) -> Any:
        for axis in self._axes():
            effects = axis.sensor_effects(effects, self.fields)
        return effects
