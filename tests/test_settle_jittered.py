"""The generator's physics check with the jittered layouts: a rod that lies still at its nominal place and rolls
away from a jittered one (the layouts `robolab validate` starts from) makes the scene unstable."""

from __future__ import annotations

from robolab_ms.catalog import load_catalog
from robolab_ms.generation.settle import settle
from robolab_ms.scene import read_scene

SCENE = """name: rolling_rod
description: a screwdriver that rolls from some jittered layouts
table: {size: [0.9, 1.2], color: brown}
jitter: {xy: 0.01, yaw_deg: 5}
objects:
  - {name: cordless_drill, asset: cordless_drill, xy: [0.5209, 0.0]}
  - {name: hammer_red, asset: hammer_red, xy: [0.5612, -0.1225]}
  - {name: screwdriver, asset: screwdriver, xy: [0.3, -0.1225]}
  - {name: spring_clamp, asset: spring_clamp, xy: [0.782, 0.0]}
"""


def test_a_rod_that_rolls_from_a_jittered_layout_is_caught(tmp_path):
    catalog = load_catalog()
    file = tmp_path / "rolling_rod.yaml"
    file.write_text(SCENE, encoding="utf-8")
    spec = read_scene(file, catalog)
    assert settle(spec, {}, catalog).stable  # at the nominal layout it lies still
    jittered = settle(spec, {}, catalog, jittered_seeds=3)
    assert set(jittered.moved()) == {"screwdriver"}
