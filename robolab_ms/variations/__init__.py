"""Domain randomization: every axis RoboLab perturbs and more, drawn from the episode seed, recorded per episode.

Axes (one module each): `lighting` (intensity, key light colour and direction, ambient), `background` (HDR map),
`table` (material), `camera` (pose offsets of the external and wrist cameras), `objects` (x, y, yaw offsets from
the layout with collision-aware rejection sampling), `robot` (initial arm joint offsets), `noise` (Gaussian image
noise) and `distractors` (colour and texture swaps of objects the task does not name).

Settings, as `robolab eval --vary TEXT` or `gym.make(..., variations=TEXT or dict)`:
  AXIS                  every parameter of the axis drawn from its default range
  AXIS=VALUE            a condition (lighting=dim, camera=wrist, objects=20cm) or the axis's main parameter
                        (objects=0.2: x, y offsets within +-0.2 m; background=city/park; table=bamboo; noise=4)
  AXIS.PARAM=VALUE      one parameter: a number (an offset n means -n..n, any other number is fixed), LOW:HIGH,
                        or names separated by '/' (or `all`)
An axis named only with conditions or parameters keeps its other parameters at the scene's own values.

Each parameter draws from its own generator, seeded by the episode seed and the parameter's name: the same seed and
settings give the same parameters (and images) in a fresh or a reused environment, and changing one axis changes no
other axis's draws. The environment rebuilds its scene at every reset on the CPU simulator anyway, so looks, lights
and camera mounts are chosen while the scene is built, at no extra rebuild; object poses and robot joints are set
with the episode's state.
"""

from robolab_ms.variations.base import Context, VariationError
from robolab_ms.variations.settings import AXES, EpisodeVariation, Variations
from robolab_ms.variations.suites import BASELINE, Suite, suite_conditions, suites

__all__ = [
    "AXES",
    "BASELINE",
    "Context",
    "EpisodeVariation",
    "Suite",
    "VariationError",
    "Variations",
    "suite_conditions",
    "suites",
]
