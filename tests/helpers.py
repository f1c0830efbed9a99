"""Helpers shared by the tests: physics set-ups, a task's scene at reset (with the oracle bound to it), and killing a
parallel run as a crash would."""

import os
import signal
import subprocess
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import psutil
import torch

FIXTURES = Path(__file__).parent / "fixtures"
LAB = FIXTURES / "PredicateLab.yaml"


@contextmanager
def task_at_reset(task: str, seed: int) -> Iterator:
    """The unwrapped environment of `task` (a name) reset at `seed`, state observations on the CPU renderer, its
    evaluation context read afresh; closed afterwards."""
    import gymnasium as gym

    from robolab_ms.tasks.spec import load_task

    env = gym.make(load_task(task).env_id, obs_mode="state_dict", render_backend="cpu")
    try:
        env.reset(seed=seed)
        env.unwrapped.eval_context.refresh()
        yield env.unwrapped
    finally:
        env.close()


@contextmanager
def oracle_at_reset(task: str, seed: int) -> Iterator:
    """`task_at_reset`'s environment with the oracle bound to it and reset for `seed`: (the unwrapped environment,
    the oracle)."""
    from robolab_ms.policies import make_policy

    with task_at_reset(task, seed) as base:
        oracle = make_policy("oracle")
        oracle.bind(base)
        oracle.reset(base.instruction, base.single_action_space, seed)
        yield base, oracle


def put(env, name, xyz, quat=(1.0, 0.0, 0.0, 0.0)):
    """Teleport a scene object and stop it."""
    actor = env.objects[name]
    pose = actor.pose
    actor.set_pose(type(pose).create_from_pq(torch.tensor([xyz], dtype=torch.float32), torch.tensor([quat])))
    actor.set_linear_velocity(torch.zeros(1, 3))
    actor.set_angular_velocity(torch.zeros(1, 3))


def hold_arm_action(env, gripper: float) -> np.ndarray:
    """An action that keeps the arm where it is, with this gripper command."""
    return np.concatenate([env.arm_qpos()[0].numpy(), [gripper]]).astype(np.float32)


def kill_run_with_workers(process: subprocess.Popen, written: Callable[[], int], at_least: int, log: Path) -> None:
    """Once `written()` (episodes on disk) reaches `at_least`, SIGKILL the running `robolab` process as a crash
    would; its worker processes must die with it. Fails if the run ended first."""
    deadline = time.monotonic() + 400
    while time.monotonic() < deadline and process.poll() is None:
        if written() >= at_least:
            break
        time.sleep(0.02)
    assert process.poll() is None, f"the run ended before it could be killed:\n{log.read_text()}"
    workers = psutil.Process(process.pid).children(recursive=True)
    assert len(workers) >= 2
    os.kill(process.pid, signal.SIGKILL)
    process.wait(timeout=30)
    _, alive = psutil.wait_procs(workers, timeout=30)
    assert not alive, "worker processes outlived the killed run"
