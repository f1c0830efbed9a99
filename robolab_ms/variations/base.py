"""The parts every variation axis is made of: ranges, parameters, the axis interface and the per-episode context.

An axis (lighting, background, ...) declares its parameters. Each parameter has a nominal value (what the scene
has without variations) and a default range (what `--vary AXIS` draws from). `sample` draws the axis's recorded
fields from per-parameter random streams; the `configure_builder`, `after_build`, `camera_configs`, `initialize`
and `sensor_effects` hooks apply them at the point of the episode where each belongs. Nothing here imports the
simulator.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from robolab_ms.errors import RoboLabError, did_you_mean

if TYPE_CHECKING:
    from robolab_ms.catalog import Catalog
    from robolab_ms.tasks.spec import TaskSpec

FieldValue = float | int | str


class VariationError(RoboLabError):
    """Variation settings that cannot be used; the message names the setting and a fix."""


@dataclass(frozen=True)
class Uniform:
    """A number drawn uniformly from [low, high] (log-uniformly when `log`); fixed when low == high."""

    low: float
    high: float
    log: bool = False

    @property
    def fixed(self) -> bool:
        return self.low == self.high

    def draw(self, rng: np.random.Generator) -> float:
        if self.fixed:
            return float(self.low)
        if self.log:
            return float(math.exp(rng.uniform(math.log(self.low), math.log(self.high))))
        return float(rng.uniform(self.low, self.high))

    def describe(self) -> list[float]:
        return [self.low, self.high]


@dataclass(frozen=True)
class Choice:
    """One of `options`, each equally likely; fixed when there is one."""

    options: tuple[str, ...]

    @property
    def fixed(self) -> bool:
        return len(self.options) == 1

    def draw(self, rng: np.random.Generator) -> str:
        if self.fixed:
            return self.options[0]
        return self.options[int(rng.integers(len(self.options)))]

    def describe(self) -> list[str]:
        return list(self.options)


@dataclass(frozen=True)
class Names:
    """A set of names (objects of the scene); None = all of them."""

    names: tuple[str, ...] | None = None

    def describe(self) -> list[str] | str:
        return "all" if self.names is None else list(self.names)


Range = Uniform | Choice | Names


@dataclass(frozen=True)
class Param:
    """One parameter of an axis.

    kind: `offset` (a number n means -n..n), `value` (a number is a fixed value), `choice` (names, `a/b/c`) or
    `names` (a set of scene objects). nominal: the value without variations; default: the range of a bare
    `--vary AXIS`; low, high: the allowed values of a range; options: the valid choices (None: any, checked later).
    """

    name: str
    kind: str
    nominal: Range
    default: Range
    help: str
    low: float = -math.inf
    high: float = math.inf
    log: bool = False
    unit: str = ""
    options: Callable[[], Sequence[str]] | None = None

    def parse(self, value: Any, where: str) -> Range:
        """A range from text (`0.2`, `0.1:0.3`, `red/blue`, `all`) or a Python value (number, [low, high], names)."""
        if self.kind in ("choice", "names"):
            names = _names(value, where)
            if names == ("all",):
                return Names(None) if self.kind == "names" else Choice(tuple(self.options()))
            if self.kind == "names":
                return Names(names)
            known = list(self.options())
            for name in names:
                if name not in known:
                    hint = did_you_mean(name, known)
                    raise VariationError(f"{where}: '{name}' is not one of the {self.help}. {hint}")
            return Choice(names)
        low, high = _numbers(value, where)
        if high is None:
            low, high = (-abs(low) or 0.0, abs(low)) if self.kind == "offset" else (low, low)
        if low > high:
            raise VariationError(f"{where}: the range {low:g}:{high:g} is empty; write LOW:HIGH with LOW <= HIGH")
        if low < self.low or high > self.high:
            raise VariationError(
                f"{where}: {self.name} must stay within {self.low:g}..{self.high:g}{self.unit}, got {low:g}..{high:g}"
            )
        if self.log and low <= 0:
            raise VariationError(f"{where}: {self.name} must be above 0, got {low:g}")
        return Uniform(low, high, self.log)


def _names(value: Any, where: str) -> tuple[str, ...]:
    if isinstance(value, str):
        names = tuple(part.strip() for part in value.split("/"))
    elif isinstance(value, (list, tuple)) and all(isinstance(item, str) for item in value):
        names = tuple(value)
    else:
        raise VariationError(f"{where}: expected names (e.g. red/blue or all), got {value!r}")
    if not names or any(not name for name in names):
        raise VariationError(f"{where}: an empty name; separate names with '/', e.g. red/blue")
    return names


def _numbers(value: Any, where: str) -> tuple[float, float | None]:
    """(low, high) from `a:b` or [a, b]; (value, None) from one number."""
    try:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            pair: list[Any] = [value]
        elif isinstance(value, str):
            pair = value.split(":")
        elif isinstance(value, (list, tuple)):
            pair = list(value)
        else:
            raise ValueError
        numbers = [float(item) for item in pair]
        if len(numbers) not in (1, 2) or not all(math.isfinite(n) for n in numbers):
            raise ValueError
    except (TypeError, ValueError):
        raise VariationError(f"{where}: expected a number (0.2) or a range (0.1:0.3), got {value!r}") from None
    return numbers[0], (numbers[1] if len(numbers) == 2 else None)


@dataclass(frozen=True)
class Context:
    """What the axes may know about the episode's environment when they draw: the task (its scene and objects),
    the catalog, the policy cameras in use and the number of arm joints."""

    task: TaskSpec
    catalog: Catalog
    cameras: tuple[str, ...]
    arm_joints: int


def stream(seed: int, *names: str) -> np.random.Generator:
    """A random generator for one parameter of one episode: seeded by the episode seed and the parameter's name, so
    turning one axis on or changing one range never changes what another parameter draws."""
    keys = [zlib.crc32(name.encode()) for name in names]
    return np.random.default_rng([int(seed) % 2**64, *keys])


class Axis:
    """One kind of variation. Subclasses set `name`, `params`, `shorthand` (the parameter `AXIS=VALUE` sets, or
    None), `presets` (`AXIS=NAME` -> parameter values) and `summary`, and implement `sample` and the hooks they need."""

    name: str = ""
    summary: str = ""
    params: tuple[Param, ...] = ()
    shorthand: str | None = None
    presets: dict[str, dict[str, Any]] = {}

    def param(self, name: str, where: str) -> Param:
        for param in self.params:
            if param.name == name:
                return param
        known = [param.name for param in self.params]
        raise VariationError(f"{where}: '{name}' is not a parameter of {self.name}. {did_you_mean(name, known)}")

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        """The axis's recorded fields for the episode `seed` (drawn with `stream(seed, axis, parameter)`)."""
        raise NotImplementedError

    def draw(self, ranges: dict[str, Range], seed: int, name: str) -> Any:
        """Draw parameter `name` of this axis for episode `seed`."""
        return ranges[name].draw(stream(seed, self.name, name))

    # hooks, applied by robolab_ms.variations.EpisodeVariation; each gets the episode's fields (all axes')
    def configure_builder(self, builder: Any, fields: dict[str, FieldValue]) -> None:
        """Before the scene is built (room, lights, table)."""

    def after_build(self, builder: Any, fields: dict[str, FieldValue], context: Context) -> None:
        """After the scene's actors are built (their looks); only in a scene that renders."""

    def camera_configs(self, configs: list, fields: dict[str, FieldValue]) -> list:
        """The policy cameras' configurations (asked only when the scene renders)."""
        return configs

    def initialize(self, env: Any, env_idx: Any, ranges: dict[str, Range], fields: dict[str, FieldValue]) -> None:
        """When the episode's state is set (object poses, robot joints); may add fields."""

    def sensor_effects(self, effects: Any, fields: dict[str, FieldValue]) -> Any:
        """The policy cameras' sensor effects."""
        return effects
