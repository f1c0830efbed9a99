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


@pytest.fixture(scope="session")
def predicate_lab():
    """The PredicateLab test task (tests/fixtures), state observations only."""
    from helpers import LAB

    from robolab_ms.envs import RoboLabEnv

    env = RoboLabEnv(task=str(LAB), obs_mode="state_dict", render_backend="cpu")
    yield env
    env.close()


@pytest.fixture()
def lab(predicate_lab):
    """The PredicateLab environment, freshly reset to seed 0."""
    predicate_lab.reset(seed=0)
    return predicate_lab
