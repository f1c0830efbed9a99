"""Backgrounds and table materials: listed with licences, named by scene files, applied by the scene builder."""

from __future__ import annotations

import pytest
import sapien

from robolab_ms.errors import SpecError
from robolab_ms.scene import load_scene, read_scene
from robolab_ms.scene.backgrounds import load_looks
from robolab_ms.scene.scene_env import SceneOnlyEnv


def test_backgrounds_and_table_materials_are_installed_with_licences():
    looks = load_looks()
    assert len(looks.backgrounds) >= 10 and len(looks.table_materials) >= 4
    for item in [*looks.backgrounds.values(), *looks.table_materials.values()]:
        assert item.license and item.path().is_file(), item.name


def test_scene_names_a_background_and_a_table_material():
    scene = load_scene("kitchen_table")
    assert scene.background == "studio" and scene.table_material == "light_wood"
    assert len(scene.objects) == 20


def test_unknown_background_is_explained(tmp_path):
    file = tmp_path / "s.yaml"
    file.write_text("name: s\nbackground: studoi\nobjects: [{asset: banana, xy: [0.5, 0.0]}]\n")
    with pytest.raises(SpecError, match=r"background.*Did you mean 'studio'"):
        read_scene(file)


def test_builder_applies_background_and_texture_and_objects_settle():
    env = SceneOnlyEnv(load_scene("kitchen_table"))
    try:
        env.reset(seed=0)
        sub_scene = env.scene.sub_scenes[0]
        assert sub_scene.render_system.cubemap is not None
        table_visual = env.builder.table._objs[0].find_component_by_type(sapien.render.RenderBodyComponent)
        assert table_visual.render_shapes[0].material.base_color_texture is not None
        start = {name: actor.pose.p.clone() for name, actor in env.builder.objects.items()}
        for _ in range(160):  # physics steps, 1.3 s
            env.scene.step()
        moved = {name: float((actor.pose.p - start[name]).norm()) for name, actor in env.builder.objects.items()}
        assert max(moved.values()) < 0.03, {name: value for name, value in moved.items() if value > 0.01}
    finally:
        env.close()
