"""Recordings, replays, videos, adaptive episodes and task selection, end to end through the `robolab` command
(in this process, to share its start-up; `robolab replay` and ManiSkill's replay tool also as programs)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import h5py
import numpy as np
import pandas as pd
import pytest

from robolab_ms.agents.droid_model import TCP_DEPTH
from robolab_ms.analysis.tables import success_interval
from robolab_ms.cli import main
from robolab_ms.eval.metrics import METRIC_KEYS, trajectory_metrics
from robolab_ms.eval.recording import replay_recording

ROBOLAB = str(Path(sys.executable).with_name("robolab"))
STEPS = 12
TASK = "BananaInBowl"


def robolab(*args: str, timeout: int = 600) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOLAB, *args], capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """Two short random-policy episodes recorded with images and videos."""
    out = tmp_path_factory.mktemp("recorded")
    code = main(
        [
            "eval",
            "--policy",
            "random",
            "--task",
            TASK,
            "--episodes",
            "2",
            "--max-steps",
            str(STEPS),
            "--record-images",
            "--video",
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert code == 0
    return out


def lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]


def test_result_lines_carry_metrics_tallies_and_files(recorded):
    results = lines(recorded)
    assert [r["seed"] for r in results] == [0, 1]
    for result in results:
        assert result["metrics"]["ee_path_length"] > 0  # a random policy moves the arm
        assert result["metrics"]["joint_rmse_mean"] > 0
        assert set(result["metrics"]) == set(METRIC_KEYS) and result["version"] == 2
        assert sum(result["event_counts"].values()) == len(result["events"])
        assert (recorded / result["recording"]).exists() and (recorded / result["video"]).exists()
    summary = pd.read_csv(recorded / "summary.csv")
    assert {"ee_sparc", "ee_sparc_sd", "ee_speed_mean_cm_s", "gripper_fully_closed"} <= set(summary.columns)
    per_task = pd.read_csv(recorded / "tasks" / f"{TASK}.csv")
    assert per_task["seed"].tolist() == [0, 1] and "joint_rmse_mean_rad" in per_task.columns
    manifest = json.loads((recorded / "manifest.json").read_text())
    assert "--record-images" in manifest["rerun"] and "--video" in manifest["rerun"]
    assert manifest["config"]["max_steps"] == STEPS
    assert manifest["env_kwargs"]["obs_mode"] == "none"  # the random policy reads no observation: none are built


def test_recording_is_a_maniskill_trajectory_with_our_extras(recorded):
    file = recorded / lines(recorded)[0]["recording"]
    meta = json.loads(file.with_suffix(".json").read_text())
    assert meta["env_info"]["env_id"] == f"RoboLab-{TASK}-v1"
    assert meta["episodes"][0]["reset_kwargs"]["seed"] == meta["episodes"][0]["episode_seed"] == 0
    assert meta["episodes"][0]["elapsed_steps"] == STEPS
    assert meta["robolab"]["cameras"] == ["external_left", "wrist"]
    with h5py.File(file) as h5:
        traj = h5["traj_0"]
        assert traj["actions"].shape == (STEPS, 8) and traj["success"].shape == (STEPS,)
        assert traj["robolab/joint_position"].shape == (STEPS + 1, 7)
        assert traj["obs/extra/gripper_position"].shape == (STEPS + 1, 1)
        assert traj["env_states/articulations/droid"].shape[0] == STEPS + 1
        images = traj["obs/sensor_data/external_left/rgb"]
        assert images.shape == (STEPS + 1, 180, 320, 3) and images.dtype == np.uint8
        assert images[-1].std() > 10  # a rendered scene, not a blank frame
        assert np.allclose(traj["robolab/joint_position"][1:], traj["robolab/joint_position"][1:])


def test_metrics_of_a_line_follow_the_gripper_base_link_of_its_recording(recorded):
    result = lines(recorded)[0]
    with h5py.File(recorded / result["recording"]) as h5:
        traj = h5["traj_0"]
        base, tcp = traj["robolab/gripper_base_position"][()], traj["obs/extra/tcp_pose"][()][:, :3]
        joints, velocity = traj["robolab/joint_position"][()], traj["robolab/joint_velocity"][()]
        targets = traj["actions"][()][:, :7]
    assert base.shape == (STEPS + 1, 3) and velocity.shape == (STEPS + 1, 7)
    # the base link stays TCP_DEPTH from the point between the pads, wherever the gripper goes
    assert np.allclose(np.linalg.norm(tcp - base, axis=1), TCP_DEPTH, atol=1e-4)
    assert np.linalg.norm(base[-1] - base[0]) > 0.01  # and it moved
    expected = trajectory_metrics(base, joints, targets, 1 / 15, joint_velocities=velocity)
    for key, value in expected.items():
        assert result["metrics"][key] == pytest.approx(value, rel=1e-4, abs=1e-6), key


def test_robolab_replay_reproduces_every_recorded_episode(recorded):
    run = robolab("replay", str(recorded))
    assert run.returncode == 0, run.stdout + run.stderr
    assert "2/2 recording(s) reproduced exactly" in run.stdout
    # the second episode alone, in a new environment: no help from the first episode
    report = replay_recording(recorded / lines(recorded)[1]["recording"])
    assert report.matches and report.max_state_difference == 0.0 and report.steps == STEPS


def test_robolab_replay_notices_a_changed_action(recorded, tmp_path):
    source = recorded / lines(recorded)[0]["recording"]
    copy = tmp_path / source.name
    shutil.copy(source, copy)
    shutil.copy(source.with_suffix(".json"), copy.with_suffix(".json"))
    with h5py.File(copy, "r+") as h5:
        h5["traj_0/actions"][5, 0] += 0.3
    report = replay_recording(copy)
    assert not report.matches and report.first_different_step == 6  # the state after the changed sixth action
    assert main(["replay", str(copy)]) == 1


def test_maniskill_replay_tool_replays_our_recording(recorded, tmp_path):
    source = recorded / lines(recorded)[1]["recording"]
    file = tmp_path / source.name
    shutil.copy(source, file)
    shutil.copy(source.with_suffix(".json"), file.with_suffix(".json"))
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "mani_skill.trajectory.replay_trajectory",
            "--traj-path",
            str(file),
            "--save-traj",
            "--allow-failure",
            "-o",
            "state_dict",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "TQDM_DISABLE": "1"},
    )
    assert run.returncode == 0, run.stderr[-3000:]
    replayed = file.with_name(f"{file.stem}.state_dict.pd_joint_pos.physx_cpu.h5")
    with h5py.File(file) as ours, h5py.File(replayed) as theirs:
        a, b = ours["traj_0/env_states"], theirs["traj_0/env_states"]
        for kind in ("actors", "articulations"):
            for name in a[kind]:
                assert np.array_equal(a[kind][name][()], b[kind][name][()]), name


def test_video_has_a_frame_per_step_with_cameras_and_caption(recorded):
    video = recorded / lines(recorded)[0]["video"]
    capture = cv2.VideoCapture(str(video))
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    assert len(frames) == STEPS + 1  # the reset state, then one frame per step
    height, width = frames[0].shape[:2]
    assert width == 640 and height % 16 == 0 and height > 180 + 360
    assert frames[-1][:180].std() > 10 and frames[-1][180:540].std() > 10  # policy views, then the video camera
    assert not list(video.parent.glob("*.partial.mp4"))


def test_adaptive_episodes_stop_once_the_interval_is_narrow_enough(tmp_path):
    width = 0.25
    command = (
        "eval",
        "--policy",
        "random",
        "--task",
        TASK,
        "--episodes-adaptive",
        "30",
        "--ci-width",
        str(width),
        "--max-steps",
        "1",
        "--out",
        str(tmp_path),
        "--quiet",
    )
    assert main(list(command)) == 0
    outcomes = [r["success"] for r in lines(tmp_path)]
    n = len(outcomes)
    low, high = success_interval(sum(outcomes), n)
    assert 10 <= n < 30 and high - low <= width
    low, high = success_interval(sum(outcomes[:-1]), n - 1)
    assert n == 10 or high - low > width  # not one episode more than needed
    assert main(list(command)) == 0 and len(lines(tmp_path)) == n  # a rerun has nothing to add


@pytest.mark.slow
def test_list_and_eval_choose_tasks_by_filters(tmp_path, capsys):
    from robolab_ms.tasks.spec import load_all_tasks, task_names

    assert main(["list", "--tag", "spatial", "--difficulty", "moderate"]) == 0
    words = [line.split() for line in capsys.readouterr().out.splitlines()]
    listed = {row[0] for row in words if row and row[0] in task_names()}
    expected = {s.name for s in load_all_tasks() if "spatial" in s.attributes and s.difficulty == "moderate"}
    assert listed == expected and expected
    assert main(["list", "--task", "all", "--scene", "colored_blocks"]) == 0
    assert "\n2 task(s)" in capsys.readouterr().out
    assert (
        main(["eval", "--task", "all", "--difficulty", "complex", "--scene", "banana_bowl", "--out", str(tmp_path)])
        == 2
    )
    assert "no task matches difficulty complex, scene banana_bowl" in capsys.readouterr().err
    assert main(["eval", "--tag", "spatail", "--out", str(tmp_path)]) == 2
    assert "Did you mean 'spatial'" in capsys.readouterr().err
    for command in ("eval", "validate"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        assert "%%" not in capsys.readouterr().out


def test_video_encoder_keeps_ended_videos_and_drops_an_unfinished_one(tmp_path):
    from robolab_ms.eval.video import Caption, EpisodeVideo

    views = {"external_left": np.full((180, 320, 3), 90, np.uint8), "wrist": np.full((180, 320, 3), 160, np.uint8)}
    wide = np.full((360, 640, 3), 200, np.uint8)
    encoder = EpisodeVideo()
    encoder.begin(tmp_path / "done.mp4")
    for step in range(7):
        encoder.add(
            views,
            wide,
            Caption(
                "Put the banana in the bowl.",
                step,
                6,
                0.5,
                step == 6,
                [{"step": 2, "type": "object_bumped", "object": "apple"}],
            ),
        )
    encoder.end()
    encoder.begin(tmp_path / "interrupted.mp4")
    encoder.add(views, wide, Caption("x", 0, 6))
    encoder.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["done.mp4"]
    capture = cv2.VideoCapture(str(tmp_path / "done.mp4"))
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 7
