"""`robolab export lerobot`: recorded episodes as a LeRobot v3.0 dataset, checked file by file against the layout
LeRobot documents (LeRobot itself does not install here) with pyarrow and a video decoder."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import h5py
import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.export_lerobot import export_lerobot
from robolab_ms.eval.recording import RecordOptions
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy

ROBOLAB = str(Path(sys.executable).with_name("robolab"))
EPISODES, STEPS, FPS = 3, 5, 15
CAMERAS = ("observation.images.external_left", "observation.images.wrist")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """Three random-policy episodes recorded with images; seed 1 marked successful, as if it had been."""
    out = tmp_path_factory.mktemp("recorded")
    config = EvalConfig(tasks=("BananaInBowl",), episodes=EPISODES, max_steps=STEPS, record=RecordOptions(True, True))
    run_evaluation(make_policy("random"), config, out, show_progress=False)
    meta_file = out / "recordings/BananaInBowl/default-droid-random-seed1.json"
    meta = json.loads(meta_file.read_text())
    meta["robolab"]["success"] = True
    meta_file.write_text(json.dumps(meta))
    return out


def decoded_frames(path: Path) -> tuple[np.ndarray, list[float]]:
    """Every frame of an mp4 as RGB, and each frame's timestamp in seconds."""
    capture = cv2.VideoCapture(str(path))
    frames, times = [], []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        times.append(capture.get(cv2.CAP_PROP_POS_MSEC) / 1000.0)
        frames.append(frame[..., ::-1])
    capture.release()
    return np.asarray(frames), times


def test_export_writes_the_documented_v3_layout(run_dir, tmp_path):
    out = tmp_path / "dataset"
    result = subprocess.run(
        [ROBOLAB, "export", "lerobot", str(run_dir), str(out)], capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "3 episode(s), 15 frame(s)" in result.stdout

    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == FPS and info["robot_type"] == "droid"
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] == "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    assert (info["total_episodes"], info["total_frames"], info["total_tasks"]) == (EPISODES, EPISODES * STEPS, 1)
    assert info["splits"] == {"train": "0:3"} and info["chunks_size"] == 1000
    features = info["features"]
    for name in ("observation.state", "action"):
        assert features[name]["dtype"] == "float32" and features[name]["shape"] == [8]
        assert features[name]["names"][-1] == "gripper"
    for name, dtype in (
        ("timestamp", "float32"),
        ("frame_index", "int64"),
        ("episode_index", "int64"),
        ("index", "int64"),
        ("task_index", "int64"),
        ("next.done", "bool"),
    ):
        assert features[name] == {"dtype": dtype, "shape": [1], "names": None}
    for key in CAMERAS:
        assert features[key]["dtype"] == "video" and features[key]["shape"] == [180, 320, 3]
        assert features[key]["info"]["video.fps"] == FPS and features[key]["info"]["video.codec"] == "h264"

    tasks = pd.read_parquet(out / "meta/tasks.parquet")
    assert tasks.index.name == "task" and list(tasks.index) == ["Put the banana in the bowl."]
    assert tasks["task_index"].tolist() == [0]

    episodes_table = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet")
    episodes = episodes_table.to_pandas()
    assert episodes["episode_index"].tolist() == [0, 1, 2] and episodes["length"].tolist() == [STEPS] * 3
    assert episodes["success"].tolist() == [False, True, False] and episodes["seed"].tolist() == [0, 1, 2]
    assert [list(t) for t in episodes["tasks"]] == [["Put the banana in the bowl."]] * 3
    assert episodes["dataset_from_index"].tolist() == [0, 5, 10] and episodes["dataset_to_index"].tolist() == [
        5,
        10,
        15,
    ]
    assert (episodes["meta/episodes/chunk_index"] == 0).all() and (episodes["data/file_index"] == 0).all()
    for key in CAMERAS:
        assert episodes[f"videos/{key}/from_timestamp"].tolist() == pytest.approx([0, 5 / FPS, 10 / FPS])
        assert episodes[f"videos/{key}/to_timestamp"].tolist() == pytest.approx([5 / FPS, 10 / FPS, 15 / FPS])
        assert np.asarray(episodes_table[f"stats/{key}/mean"].to_pylist()[0]).shape == (3, 1, 1)
    assert np.asarray(episodes_table["stats/action/mean"].to_pylist()[0]).shape == (8,)

    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    assert data.schema.field("observation.state").type.list_size == 8
    frame = data.to_pandas()
    assert frame["index"].tolist() == list(range(15))
    assert frame["frame_index"].tolist() == list(range(STEPS)) * 3
    assert frame["episode_index"].tolist() == [0] * 5 + [1] * 5 + [2] * 5
    assert frame["timestamp"].to_numpy() == pytest.approx(np.tile(np.arange(STEPS) / FPS, 3))
    assert frame["next.done"].tolist() == ([False] * 4 + [True]) * 3
    assert (frame["task_index"] == 0).all()
    with h5py.File(run_dir / "recordings/BananaInBowl/default-droid-random-seed2.h5", "r") as recording:
        group = recording["traj_0"]
        state = np.concatenate(
            [group["robolab/joint_position"][:STEPS], group["obs/extra/gripper_position"][:STEPS]], 1
        )
        np.testing.assert_array_equal(np.stack(frame["observation.state"][10:15]), state)
        np.testing.assert_array_equal(np.stack(frame["action"][10:15]), group["actions"][:])
        images = {key: group[f"obs/sensor_data/{key.rsplit('.', 1)[1]}/rgb"][:STEPS] for key in CAMERAS}

    stats = json.loads((out / "meta/stats.json").read_text())
    for name in ("observation.state", "action", "timestamp", "index", "next.done", *CAMERAS):
        assert {"min", "max", "mean", "std", "count", "q01", "q10", "q50", "q90", "q99"} <= set(stats[name])
    assert stats["action"]["count"] == [15] and len(stats["action"]["mean"]) == 8
    assert stats["timestamp"]["max"] == pytest.approx([4 / FPS])
    assert np.asarray(stats[CAMERAS[0]]["mean"]).shape == (3, 1, 1)
    assert 0 < np.min(stats[CAMERAS[0]]["mean"]) < np.max(stats[CAMERAS[0]]["mean"]) < 1

    for key in CAMERAS:  # one video per camera: 15 frames at 1/15 s, episode 2 from 10/15 s on, as recorded
        frames, times = decoded_frames(out / f"videos/{key}/chunk-000/file-000.mp4")
        assert frames.shape == (15, 180, 320, 3)
        assert times == pytest.approx([i / FPS for i in range(15)], abs=1e-3)
        error = np.abs(frames[10:15].astype(int) - images[key].astype(int)).mean()
        assert error < 6, f"{key}: the video's episode 2 differs from its recording by {error:.1f} on average"
        assert np.abs(frames[5:10].astype(int) - images[key].astype(int)).mean() > error  # another episode


def test_export_success_only_files_and_refusals(run_dir, tmp_path):
    small = export_lerobot(run_dir, tmp_path / "split", videos=True, frames_per_file=7)  # one episode per file
    assert small.episodes == 3
    episodes = pq.read_table(tmp_path / "split/meta/episodes/chunk-000/file-000.parquet").to_pandas()
    assert episodes["data/file_index"].tolist() == [0, 1, 2]
    assert episodes[f"videos/{CAMERAS[1]}/from_timestamp"].tolist() == [0.0, 0.0, 0.0]
    for index in range(3):
        assert len(pq.read_table(tmp_path / f"split/data/chunk-000/file-{index:03d}.parquet")) == STEPS
        assert len(decoded_frames(tmp_path / f"split/videos/{CAMERAS[1]}/chunk-000/file-{index:03d}.mp4")[0]) == STEPS

    only = export_lerobot(run_dir, tmp_path / "success", success_only=True, videos=False)
    assert (only.episodes, only.frames, only.cameras) == (1, STEPS, [])
    info = json.loads((tmp_path / "success/meta/info.json").read_text())
    assert info["video_path"] is None and not any(f["dtype"] == "video" for f in info["features"].values())
    assert not (tmp_path / "success/videos").exists()
    assert pq.read_table(tmp_path / "success/meta/episodes/chunk-000/file-000.parquet")["seed"].to_pylist() == [1]

    with pytest.raises(RoboLabError, match="not empty"):
        export_lerobot(run_dir, tmp_path / "success")
    with pytest.raises(RoboLabError, match="nothing to export"):
        export_lerobot(run_dir, tmp_path / "none", tasks=["BananaOnPlate"])
