"""Fidelity: every scene renders in a room (no grid ground, no empty background), objects carry image textures,
shadows are on; sensor effects and the render-quality switch behave."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from robolab_ms.catalog import load_catalog
from robolab_ms.catalog.appearance import SURFACES, make_texture, part_look
from robolab_ms.envs.cameras import RENDER_QUALITIES, SensorEffects, check_render_quality, shader_config
from robolab_ms.errors import RoboLabError
from robolab_ms.fidelity import (
    REAL_SHAPE_FLOOR,
    TEXTURED_TARGET,
    _fidelity_env_class,
    fidelity_report,
    measure_scene,
    shape_counts,
)
from robolab_ms.scene import load_scene, scene_names
from robolab_ms.scene.backgrounds import load_looks, panorama_image
from robolab_ms.tasks.spec import load_all_tasks


@pytest.fixture(scope="module")
def report():
    """The fidelity report over every shipped scene, rendered small (the pixel shares do not need detail)."""
    return fidelity_report(width=48, height=27)


@pytest.mark.slow
def test_every_scene_is_measured(report):
    assert not report.errors
    assert {s.scene for s in report.scenes} == set(scene_names())


def test_objects_have_image_textures(report):
    assert report.textured_share >= TEXTURED_TARGET, report.text()


def test_no_grid_ground_or_empty_background(report):
    assert report.void_share == 0.0, report.text()
    shares = report.region_shares()
    assert shares.get("room panorama", 0) > 0.02 and shares.get("floor", 0) > 0.1, shares  # the room is in view


def test_shadows_on_in_every_scene(report):
    assert report.shadows_on
    assert all(s.shadow_map_size > 0 for s in report.scenes)


def test_void_measure_catches_the_old_grid_floor(monkeypatch):
    """The measurement can fail: ManiSkill's grid ground and no backdrop show up as void pixels."""
    from mani_skill.utils.building.ground import build_ground

    from robolab_ms.scene import TABLE_HEIGHT
    from robolab_ms.scene.builder import RoboLabSceneBuilder

    monkeypatch.setattr(
        RoboLabSceneBuilder, "_build_floor", lambda self: build_ground(self.scene, altitude=-TABLE_HEIGHT)
    )
    monkeypatch.setattr(RoboLabSceneBuilder, "_build_backdrop", lambda self: None)
    spec = load_scene("banana_bowl")
    env = _fidelity_env_class()(spec, 48, 27)
    try:
        scene = measure_scene(env, spec)
    finally:
        env.close()
    assert scene.regions.get("grid ground", 0) > 0
    assert scene.void_pixels / scene.pixels > 0.2


@pytest.fixture(scope="module")
def tasks():
    return load_all_tasks()


def test_real_shape_share_holds_the_floor_and_is_what_the_docs_say(tasks):
    """Task-target instances with a scanned or modelled shape, counted from the catalog, scenes and tasks."""
    counts = shape_counts(tasks=tasks)
    assert counts.target_share >= REAL_SHAPE_FLOOR, counts.text()
    assert sum(counts.targets.values()) > 150 and sum(counts.instances.values()) > 350  # every RoboLab-120 task
    docs = (Path(__file__).parents[1] / "docs" / "fidelity.md").read_text(encoding="utf-8")
    assert counts.text() in docs, f"docs/fidelity.md should show:\n{counts.text()}"


def test_shape_counts_count_each_target_once_per_scene(tasks):
    """bananas_5_grey_bin's three tasks name five bananas, some in two or three tasks; colored_blocks' two tasks the
    same four blocks: nine target instances, each counted once."""
    catalog = load_catalog()
    counts = shape_counts(["bananas_5_grey_bin", "colored_blocks"], tasks)
    banana = catalog[load_scene("bananas_5_grey_bin").placement("banana").asset].shape
    assert counts.tasks == 5 and counts.scenes == 2
    assert sum(counts.targets.values()) == 9 and counts.targets[banana] >= 5
    assert counts.targets["primitive"] >= 4  # the four wooden blocks
    assert sum(counts.instances.values()) == len(load_scene("bananas_5_grey_bin").objects) + 4


def test_every_catalog_object_gets_a_known_surface():
    for entry in load_catalog().objects.values():
        for tint in range(max(1, len(entry.colors))):
            assert part_look(entry, tint).kind in SURFACES


def test_textures_are_images_and_repeatable():
    a = make_texture("label", (0.8, 0.1, 0.1))
    assert a.shape[2] == 3 and a.dtype == np.uint8 and a.std() > 10  # not a flat colour
    assert np.array_equal(a, make_texture("label", (0.8, 0.1, 0.1)))
    sticker = make_texture("sticker", (0.15, 0.3, 0.8))
    assert (sticker.reshape(-1, 3) < 30).all(axis=1).mean() > 0.1  # black gaps between the stickers


def test_panorama_is_a_visible_image():
    image = panorama_image(load_looks().default_background)
    assert image.ndim == 3 and 40 < image.mean() < 220 and image.std() > 20


def test_sensor_effects_default_changes_nothing():
    rgb = torch.randint(0, 256, (1, 18, 32, 3), dtype=torch.uint8)
    assert torch.equal(SensorEffects().apply(rgb, seed=0, step=0), rgb)


def test_sensor_noise_repeats_per_seed_and_step():
    rgb = torch.full((1, 18, 32, 3), 128, dtype=torch.uint8)
    effects = SensorEffects(noise=4.0)
    a, b = effects.apply(rgb, 3, 5), effects.apply(rgb, 3, 5)
    assert torch.equal(a, b) and not torch.equal(a, effects.apply(rgb, 3, 6))
    assert 2.0 < (a.float() - 128).std() < 6.0


def test_sensor_blur_and_gains():
    rgb = torch.zeros((1, 20, 20, 3), dtype=torch.uint8)
    rgb[:, :, 10:] = 200
    blurred = SensorEffects(blur=1.5).apply(rgb, 0, 0)
    assert 0 < int(blurred[0, 10, 9, 0]) < 200  # the edge is smeared
    warm = SensorEffects(exposure=0.5, white_balance=(1.2, 1.0, 0.8)).apply(rgb, 0, 0)
    assert warm[0, 0, 15].tolist() == [120, 100, 80]


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="noise"):
        SensorEffects(noise=-1.0)
    with pytest.raises(ValueError, match="unknown"):
        SensorEffects.create({"grain": 1})
    with pytest.raises(RoboLabError, match="render quality"):
        check_render_quality("ultra")
    assert RENDER_QUALITIES == ("fast", "high")
    assert shader_config("fast").shader_pack == "minimal"
    high = shader_config("high")
    assert high.shader_pack == "rt" and high.shader_pack_config["ray_tracing_denoiser"] == "oidn"


def test_env_applies_sensor_effects():
    from robolab_ms.envs import RoboLabEnv

    kwargs = dict(task="BananaInBowl", obs_mode="rgb", render_backend="cpu", camera_width=64, camera_height=36)
    clean = RoboLabEnv(**kwargs)
    noisy = RoboLabEnv(**kwargs, sensor_effects={"noise": 8.0})
    try:
        a = clean.reset(seed=1)[0]["sensor_data"]["external_left"]["rgb"]
        b = noisy.reset(seed=1)[0]["sensor_data"]["external_left"]["rgb"]
        c = noisy.reset(seed=1)[0]["sensor_data"]["external_left"]["rgb"]
    finally:
        clean.close(), noisy.close()
    assert not torch.equal(a, b) and torch.equal(b, c)
    assert (a.float() - b.float()).abs().mean() > 2.0
