"""Shared fixtures: one rendering BananaInBowl environment for the whole session (creating one takes seconds)."""

from __future__ import annotations

import gymnasium as gym
import mani_skill.envs  # noqa: F401  (also registers the RoboLab environments)
import pytest


@pytest.fixture(scope="session")
def banana_env():
    env = gym.make("RoboLab-BananaInBowl-v1", obs_mode="rgb", render_backend="cpu")
    yield env
    env.close()
