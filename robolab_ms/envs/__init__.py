"""ManiSkill environments: importing this module registers `RoboLab-<Task>-v1` for every known task spec.

Known tasks are the shipped ones and those of user content folders (ROBOLAB_CONTENT, see robolab_ms.content); a task
file given by path (the CLI's `--task path/T.yaml`) is registered on demand by `register_task_file`. Registration
reads only each spec's episode length, so a broken spec cannot stop the others from registering; the full check runs
when its environment is made and reports the file and field at fault.

Every id's time limit is the episode length of the task the environment actually loaded: `gym.make(id,
task="path/T.yaml")` gets T's length, not the id's (see `use_the_task_episode_length`).
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import WrapperSpec
from mani_skill import logger as maniskill_logger
from mani_skill.utils.registration import REGISTERED_ENVS, register_env

from robolab_ms.content import content_dir, content_files, load_yaml
from robolab_ms.envs.droid_obs import DroidObservation
from robolab_ms.envs.robolab_env import RoboLabEnv
from robolab_ms.errors import RoboLabError
from robolab_ms.tasks.spec import CONTROL_HZ

DEFAULT_EPISODE_SECONDS = 60.0
TASK_LENGTH_WRAPPER = WrapperSpec("RoboLabTaskEpisodeLength", f"{__name__}:use_the_task_episode_length", {})


def use_the_task_episode_length(env: gym.Env) -> gym.Env:
    """The last wrapper step of every RoboLab id (returns `env` itself): set the time limits to the episode length of
    the task the environment loaded, unless `gym.make` was given `max_episode_steps`."""
    caller = sys._getframe(1)  # gymnasium's make(), as ManiSkill's own TimeLimitWrapper reads it
    if caller.f_code.co_name == "make" and caller.f_locals.get("max_episode_steps") is not None:
        return env
    steps = env.unwrapped.task_spec.max_episode_steps
    layer: Any = env
    while isinstance(layer, gym.Wrapper):
        if hasattr(layer, "_max_episode_steps"):  # gymnasium's TimeLimit and ManiSkill's TimeLimitWrapper
            layer._max_episode_steps = steps
            saved = getattr(layer, "_saved_kwargs", None)
            if isinstance(saved, dict) and "max_episode_steps" in saved:
                saved["max_episode_steps"] = steps
        layer._cached_spec = None
        layer = layer.env
    return env


def _episode_steps(path: Path) -> int:
    try:
        seconds = float(load_yaml(path).get("episode_seconds", DEFAULT_EPISODE_SECONDS))
        return max(1, round(seconds * CONTROL_HZ))
    except (RoboLabError, TypeError, ValueError, OverflowError):
        return round(DEFAULT_EPISODE_SECONDS * CONTROL_HZ)  # the full check at make time names the problem


def registered_file(env_id: str) -> Path | None:
    """The task file a RoboLab id loads by default, or None when the id is not registered."""
    spec = REGISTERED_ENVS.get(env_id)
    task = None if spec is None else spec.default_kwargs.get("task")
    return None if task is None else Path(task)


def register_task_file(path: str | Path, replace: bool = False) -> str:
    """Register `RoboLab-<name>-v1` for a task file; returns the id. An id already registered for another file stays
    as it is unless `replace` (then, in this process, the id loads this file: the CLI's `--task path/T.yaml`).
    gym.make(id, task=path) loads any file under any id."""
    path = Path(path).resolve()
    env_id = f"RoboLab-{path.stem}-v1"
    known = registered_file(env_id)
    if known is None or (replace and known != path):
        quiet = maniskill_logger
        level = quiet.level
        quiet.setLevel(logging.ERROR)  # not ManiSkill's "Override registered env" warning: replacing is the point
        try:
            register_env(env_id, max_episode_steps=_episode_steps(path), override=known is not None, task=str(path))(
                RoboLabEnv
            )
        finally:
            quiet.setLevel(level)
        spec = gym.registry[env_id]
        spec.additional_wrappers = (*spec.additional_wrappers, TASK_LENGTH_WRAPPER)
    return env_id


def register_all_tasks() -> list[str]:
    """Register every known task (idempotent): the shipped ones first, then those of user content folders, whose
    problems (a folder that is missing, a name defined twice) are raised after the shipped ones are registered."""
    ids = [register_task_file(path) for path in sorted(content_dir("tasks").glob("*.yaml"))]
    for _name, path in sorted(content_files("tasks").items()):
        env_id = register_task_file(path)
        if env_id not in ids:
            ids.append(env_id)
    return ids


ENV_IDS = register_all_tasks()

__all__ = ["RoboLabEnv", "DroidObservation", "ENV_IDS", "register_all_tasks", "register_task_file", "registered_file"]
