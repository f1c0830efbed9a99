"""ManiSkill environments: importing this module registers `RoboLab-<Task>-v1` for every task spec.

Registration reads only each spec's name and episode length, so a broken spec cannot stop the others from
registering; the full check runs when its environment is made and reports the file and field at fault.
"""

from __future__ import annotations

from mani_skill.utils.registration import REGISTERED_ENVS, register_env

from robolab_ms.content import content_dir, load_yaml
from robolab_ms.envs.droid_obs import DroidObservation
from robolab_ms.envs.robolab_env import RoboLabEnv
from robolab_ms.errors import RoboLabError
from robolab_ms.tasks.spec import CONTROL_HZ

DEFAULT_EPISODE_SECONDS = 60.0


def register_all_tasks() -> list[str]:
    """Register every task spec in task_specs/ (idempotent); returns the environment ids."""
    ids = []
    for path in sorted(content_dir("tasks").glob("*.yaml")):
        env_id = f"RoboLab-{path.stem}-v1"
        ids.append(env_id)
        if env_id in REGISTERED_ENVS:
            continue
        try:
            seconds = float(load_yaml(path).get("episode_seconds", DEFAULT_EPISODE_SECONDS))
        except (RoboLabError, TypeError, ValueError):
            seconds = DEFAULT_EPISODE_SECONDS  # the full check at make time names the problem
        register_env(env_id, max_episode_steps=round(seconds * CONTROL_HZ), task=path.stem)(RoboLabEnv)
    return ids


ENV_IDS = register_all_tasks()

__all__ = ["RoboLabEnv", "DroidObservation", "ENV_IDS", "register_all_tasks"]
