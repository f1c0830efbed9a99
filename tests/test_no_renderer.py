"""State-only use without a renderer (ManiSkill's render_backend="none"): the scene has no render system, so
nothing of the look is built (room backdrop, environment map, lights, materials, textures, cameras), and episodes,
task logic and variations run as with a renderer."""

from __future__ import annotations

import gymnasium as gym
import mani_skill.envs  # noqa: F401  (registers the RoboLab environments)
import numpy as np
import pytest
import sapien
import torch

from robolab_ms.catalog import load_catalog
from robolab_ms.catalog.appearance import scene_renders
from robolab_ms.errors import RoboLabError

TASK = "RoboLab-RubiksCubeLeftOfBowl-v1"
EVERY_AXIS = "lighting,background,table,camera,objects,robot,noise,distractors"


def _states(env, seed: int, steps: int) -> list[dict]:
    """The state after reset and after each of `steps` seeded random actions."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    states = [env.unwrapped.get_state_dict()]
    for _ in range(steps):
        env.step(env.action_space.sample())
        states.append(env.unwrapped.get_state_dict())
    return states


def _flat(state: dict, prefix: str = "") -> dict[str, np.ndarray]:
    flat = {}
    for key, value in state.items():
        if isinstance(value, dict):
            flat.update(_flat(value, f"{prefix}{key}/"))
        else:
            flat[prefix + key] = torch.as_tensor(value).cpu().numpy()
    return flat


def test_scene_renders_tells_scenes_with_and_without_a_render_system():
    physics_only = sapien.Scene([sapien.physx.PhysxCpuSystem()])
    assert not scene_renders(physics_only)
    banana = load_catalog()["banana"].build(physics_only, "banana", sapien.Pose())  # collision shapes only
    assert banana.find_component_by_type(sapien.render.RenderBodyComponent) is None
    assert banana.find_component_by_type(sapien.physx.PhysxRigidDynamicComponent) is not None


def test_state_episode_without_renderer_runs_and_matches_a_rendering_one():
    blind = gym.make(TASK, obs_mode="state", render_backend="none")
    seeing = gym.make(TASK, obs_mode="state", render_backend="cpu")
    try:
        base = blind.unwrapped
        observation, info = blind.reset(seed=0)
        assert not scene_renders(base.scene) and scene_renders(seeing.unwrapped.scene)
        assert base.scene_builder.backdrop is None and base.scene.sensors == {}
        assert observation.shape == seeing.reset(seed=0)[0].shape
        observation, _, _, _, info = blind.step(blind.action_space.sample())
        assert {"success", "score", "progress", "events"} <= set(info)
        assert set(base.evaluate()) == set(seeing.unwrapped.evaluate())
        # the look is no part of the physics: the same seed and actions give the very same states
        for without, with_renderer in zip(_states(blind, 3, 6), _states(seeing, 3, 6)):
            a, b = _flat(without), _flat(with_renderer)
            assert a.keys() == b.keys()
            assert all(np.array_equal(a[key], b[key]) for key in a), "states differ without a renderer"
    finally:
        blind.close()
        seeing.close()


def test_every_variation_axis_without_renderer():
    env = gym.make(TASK, obs_mode="state", render_backend="none", variations=EVERY_AXIS)
    try:
        first = _states(env, 5, 3)
        fields = env.unwrapped.variation_params
        for key in (
            "light_intensity",
            "background",
            "table_material",
            "cam_wrist_dx",
            "image_noise_std",
            "distractor_banana_color",
            "obj_bowl_dx",
            "robot_joint1_offset",
        ):
            assert key in fields, f"{key} not drawn without a renderer"
        again = _states(env, 5, 3)
        assert env.unwrapped.variation_params == fields
        for a, b in zip(first, again):
            assert all(np.array_equal(x, y) for x, y in zip(_flat(a).values(), _flat(b).values()))
    finally:
        env.close()


def test_image_observations_need_a_renderer():
    with pytest.raises(RoboLabError, match="render_backend='none'.*obs_mode='state'"):
        gym.make(TASK, obs_mode="rgb", render_backend="none")


def test_render_without_renderer_is_a_clear_error():
    env = gym.make(TASK, obs_mode="state", render_mode="rgb_array", render_backend="none")
    try:
        env.reset(seed=0)
        with pytest.raises(RoboLabError, match="render_backend='none'"):
            env.render()
    finally:
        env.close()
