"""ManiSkill's own tools on our environments: its demo script with and without a renderer, its RecordEpisode wrapper,
its replay_trajectory by actions and by env states (on a `robolab eval --record` file and on a RecordEpisode file),
and gymnasium's check_env, next to ManiSkill's own PickCube-v1.

ManiSkill's programs run as processes, several at a time (their time is mostly start-up)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import h5py
import mani_skill.envs  # noqa: F401  (registers ManiSkill's and our environments)
import numpy as np
import pytest
from gymnasium.utils import env_checker
from gymnasium.utils.passive_env_checker import env_reset_passive_checker, env_step_passive_checker
from mani_skill.utils.wrappers import RecordEpisode
from mani_skill.utils.wrappers.gymnasium import CPUGymWrapper

from robolab_ms.cli import main
from robolab_ms.eval.recording import replay_recording

ENV_ID = "RoboLab-BananaInBowl-v1"
STEPS = 8
TIMEOUT_S = 600


def start(*args: str) -> subprocess.Popen:
    """`python -m ...` as a process, its output captured."""
    return subprocess.Popen(
        [sys.executable, "-m", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "TQDM_DISABLE": "1"},
    )


def finish(process: subprocess.Popen) -> tuple[int, str, str]:
    out, err = process.communicate(timeout=TIMEOUT_S)
    return process.returncode, out, err


def leaves(group: h5py.Group, prefix: str = "") -> dict[str, np.ndarray]:
    found = {}
    for key, item in group.items():
        if isinstance(item, h5py.Group):
            found.update(leaves(item, f"{prefix}{key}/"))
        else:
            found[prefix + key] = item[()]
    return found


def env_states(file: Path) -> dict[str, np.ndarray]:
    with h5py.File(file) as h5:
        return leaves(h5["traj_0/env_states"])


# ---------------------------------------------------------------------------------------------------- demo
@pytest.mark.slow
def test_demo_random_action_runs_a_whole_episode_with_and_without_a_renderer():
    demo = ("mani_skill.examples.demo_random_action", "-e", ENV_ID, "-s", "0")
    runs = {"renderer": start(*demo), "none": start(*demo, "--render-mode", "none", "-rb", "none")}
    for name, process in runs.items():
        code, out, err = finish(process)
        assert code == 0, f"{name}: {err[-3000:]}"
        assert "Traceback" not in err and "Observation space" in out, name
        assert out.rstrip().splitlines()[-3:-1] == ["terminated tensor([False])", "truncated tensor([True])"], name


# ---------------------------------------------------------------------------------------------------- recording
@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> dict[str, Path]:
    """One short random episode recorded by `robolab eval --record`, one by ManiSkill's RecordEpisode wrapper."""
    out = tmp_path_factory.mktemp("robolab_eval")
    assert (
        main(
            [
                "eval",
                "--policy",
                "random",
                "--task",
                "BananaInBowl",
                "--episodes",
                "1",
                "--max-steps",
                str(STEPS),
                "--record",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    (robolab_file,) = (out / "recordings" / "BananaInBowl").glob("*.h5")
    folder = tmp_path_factory.mktemp("record_episode")
    env = gym.make(ENV_ID, obs_mode="state", render_backend="none", max_episode_steps=STEPS)
    env = RecordEpisode(env, str(folder), trajectory_name="random", save_video=False, source_type="test")
    env.reset(seed=4)
    env.action_space.seed(4)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        done = bool((terminated | truncated).any())
    env.close()
    return {"robolab": robolab_file, "record_episode": folder / "random.h5"}


def test_record_episode_wrapper_records_our_env(recordings):
    file = recordings["record_episode"]
    info = json.loads(file.with_suffix(".json").read_text())
    assert info["env_info"]["env_id"] == ENV_ID and info["episodes"][0]["elapsed_steps"] == STEPS
    states = env_states(file)
    assert {"actors/banana", "actors/bowl", "articulations/droid", "episode/seed", "episode/step"} <= set(states)
    assert all(len(value.shape) == 2 and value.shape[0] == STEPS + 1 for value in states.values())
    assert states["episode/seed"].ravel().tolist() == [4] * (STEPS + 1)
    assert states["episode/step"].ravel().tolist() == list(range(STEPS + 1))


@pytest.fixture(scope="module")
def replays(recordings, tmp_path_factory) -> dict[tuple[str, str], tuple[Path, Path]]:
    """ManiSkill's replay_trajectory on both recordings, by actions and by env states (all at once):
    {(source, mode): (recorded file, replayed file)}."""
    started = {}
    for source, recorded in recordings.items():
        for mode, flags in (("actions", ()), ("env_states", ("--use-env-states",))):
            folder = tmp_path_factory.mktemp(f"{source}_{mode}")
            copy = folder / recorded.name
            shutil.copy(recorded, copy)
            shutil.copy(recorded.with_suffix(".json"), copy.with_suffix(".json"))
            process = start(
                "mani_skill.trajectory.replay_trajectory",
                "--traj-path",
                str(copy),
                *flags,
                "-o",
                "state",
                "--save-traj",
                "--allow-failure",
            )
            started[(source, mode)] = (copy, process)
    done = {}
    for key, (copy, process) in started.items():
        code, out, err = finish(process)
        assert code == 0, f"{key}: {err[-3000:]}"
        assert "Replayed 1 episodes, 1/1" in out, f"{key}: {out[-2000:]}"
        done[key] = (copy, copy.with_name(f"{copy.stem}.state.pd_joint_pos.physx_cpu.h5"))
    return done


@pytest.mark.parametrize("source", ["robolab", "record_episode"])
def test_replay_by_actions_gives_the_recorded_states(replays, source):
    recorded, replayed = (env_states(file) for file in replays[(source, "actions")])
    assert recorded.keys() == replayed.keys()
    for key in recorded:
        assert np.array_equal(recorded[key], replayed[key]), key


@pytest.mark.parametrize("source", ["robolab", "record_episode"])
def test_replay_by_env_states_gives_the_recorded_states(replays, source):
    recorded, replayed = (env_states(file) for file in replays[(source, "env_states")])
    assert recorded.keys() == replayed.keys()
    for key in recorded:
        assert replayed[key].shape == recorded[key].shape, key
        # after every step: exactly the recorded state (each set_state_dict restores bit for bit)
        assert np.array_equal(recorded[key][1:], replayed[key][1:]), key
        # row 0: ManiSkill 3.0.1's replay_trajectory writes the recorded state after step 1 in place of the
        # initial one (it drops the first state before it overwrites its own first row with "the first" one)
        assert np.array_equal(replayed[key][0], recorded[key][1]), key


def test_robolab_replay_of_the_recording_stays_bit_exact(recordings):
    report = replay_recording(recordings["robolab"])
    assert report.matches and report.max_state_difference == 0.0 and report.steps == STEPS


# ---------------------------------------------------------------------------------------------------- check_env
CHECKS = {
    "spaces": lambda env: (env_checker.check_action_space(env.action_space),
                           env_checker.check_observation_space(env.observation_space)),
    "reset returns (obs, info)": env_checker.check_reset_return_type,
    "reset seeds gymnasium's np_random": env_checker.check_reset_seed_determinism,
    "reset takes options": env_checker.check_reset_options,
    "reset passive checks": env_reset_passive_checker,
    "step passive checks": lambda env: env_step_passive_checker(env, env.action_space.sample()),
    "step determinism": env_checker.check_step_determinism,
    "returned data not reused": env_checker.check_returned_data_not_reused,
}  # fmt: skip


def _check_results(env: gym.Env) -> dict[str, str]:
    """Each of check_env's checks (in its order) on `env`: 'ok' or the failure; and check_env as a whole."""
    results = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # check_env's advice (infinite bounds, casting to numpy): not failures
        for name, check in {**CHECKS, "check_env": lambda e: env_checker.check_env(e, skip_render_check=True)}.items():
            try:
                check(env)
                results[name] = "ok"
            except Exception as error:  # noqa: BLE001  (the failure is the result)
                results[name] = f"{type(error).__name__}: {error}"
    return results


def test_check_env_treats_our_env_as_it_treats_pickcube():
    """check_env fails on ManiSkill's PickCube-v1 (raw and in ManiSkill's CPUGymWrapper): ManiSkill draws episodes
    from its own generators and never seeds gymnasium's `np_random`, which two of the checks demand. Our env passes
    and fails exactly the same checks, with the same messages."""
    results = {}
    for env_id in ("PickCube-v1", ENV_ID):
        env = gym.make(env_id, obs_mode="state", render_backend="none")
        try:
            results[env_id] = {
                "raw": _check_results(env.unwrapped),
                "CPUGymWrapper": _check_results(CPUGymWrapper(env)),
            }
        finally:
            env.close()
    assert results[ENV_ID] == results["PickCube-v1"]
    for kind in ("raw", "CPUGymWrapper"):
        failed = {name for name, result in results[ENV_ID][kind].items() if result != "ok"}
        assert failed == {"reset seeds gymnasium's np_random", "step determinism", "check_env"}, results[ENV_ID][kind]
        assert "random number generator" in results[ENV_ID][kind]["check_env"]
