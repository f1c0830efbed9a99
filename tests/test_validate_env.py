"""`robolab validate` runs a task's rest check and its random and oracle episodes in one environment without
observations, with a random episode's events and trajectory metrics left out; the episodes are those the evaluation
runner gives each policy in an environment of its own with state observations."""

from __future__ import annotations

from dataclasses import asdict, replace

import gymnasium as gym
from tqdm import tqdm

from robolab_ms.eval.recording import EpisodeRecorder
from robolab_ms.eval.results import TIMING_FIELDS
from robolab_ms.eval.runner import _run_episode, env_kwargs
from robolab_ms.eval.validate import ORACLE, RANDOM, REST, ValidationJob, ValidationWorker, validation_config
from robolab_ms.policies import make_policy
from robolab_ms.tasks.spec import load_task

TASK = "BananaInBowl"
STEPS = 40  # the oracle plans, reaches and closes on the banana in this many steps; the random arm flails
UNTRACKED = {"events", "event_counts", "event_objects", "metrics"}  # what a random episode's line leaves out


def eval_episode(policy_name: str, config, out, seed: int):
    """The episode as `robolab eval` runs it: a fresh environment with state observations."""
    spec = load_task(TASK)
    env = gym.make(spec.env_id, **env_kwargs(needs_images=False, config=config))
    try:
        policy = make_policy(policy_name)
        recorder = EpisodeRecorder(env, out, config.record, policy.name)
        return _run_episode(env, policy, spec, config, seed, tqdm(disable=True), recorder, out)
    finally:
        env.close()


def fields(result, leave_out=frozenset()) -> dict:
    return {key: value for key, value in asdict(result).items() if key not in TIMING_FIELDS | leave_out}


def test_validation_episodes_are_the_eval_runner_episodes(tmp_path):
    spec = load_task(TASK)
    config = replace(validation_config((str(spec.file),), 1, 0, None), max_steps=STEPS)
    worker = ValidationWorker(None, config, tmp_path, [])
    try:
        drift, solved = worker.run(ValidationJob(REST, str(spec.file), TASK, 0))
        env = worker.env
        assert env.unwrapped.obs_mode == "none"
        random, _ = worker.run(ValidationJob(RANDOM, str(spec.file), TASK, 1))
        oracle, watch = worker.run(ValidationJob(ORACLE, str(spec.file), TASK, 1))
        assert worker.env is env, "one environment for all the jobs of a task"
    finally:
        worker.close()
    assert drift < 0.02 and solved == 0
    assert random.steps == oracle.steps == STEPS and watch is not None and watch.seed == 1
    assert random.events == [] and random.metrics == {}
    assert set(oracle.metrics), "the oracle's line keeps its metrics (and its events, compared below)"
    assert fields(random, UNTRACKED) == fields(eval_episode("random", config, tmp_path, 1), UNTRACKED)
    assert fields(oracle) == fields(eval_episode("oracle", config, tmp_path, 1))
