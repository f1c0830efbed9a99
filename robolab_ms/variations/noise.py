"""Camera image noise: Gaussian noise on every pixel and channel of the policy cameras' images, its standard
deviation (8-bit levels) drawn per episode; applied by the cameras' sensor effects (robolab_ms.envs.cameras)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from robolab_ms.variations.base import Axis, Context, FieldValue, Param, Range, Uniform


class NoiseAxis(Axis):
    name = "noise"
    summary = "Gaussian image noise of the policy cameras (standard deviation in 8-bit levels)"
    params = (
        Param(
            "std", "value", Uniform(0.0, 0.0), Uniform(0.0, 8.0), "noise standard deviation", 0.0, 64.0, unit=" levels"
        ),
    )
    shorthand = "std"

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        return {"image_noise_std": round(self.draw(ranges, seed, "std"), 3)}

    def sensor_effects(self, effects: Any, fields: dict[str, FieldValue]) -> Any:
        return replace(effects, noise=float(fields["image_noise_std"]))
