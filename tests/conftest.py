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


@pytest.fixture()
def llm_server(tmp_path):
    """Start tests/llm_server.py (a real OpenAI-compatible HTTP server) with scripted answers: call it with the list
    of answers (and json_mode=False for a server refusing response_format); every server started is stopped after
    the test."""
    from llm_server import LLMServer

    started = []

    def start(answers: list, json_mode: bool = True) -> LLMServer:
        server = LLMServer(answers, tmp_path / f"llm_server_{len(started)}", json_mode=json_mode)
        started.append(server)
        return server

    yield start
    for server in started:
        server.stop()
