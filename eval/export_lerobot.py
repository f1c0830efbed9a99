"""`robolab export lerobot RUN_DIR OUT_DIR`: the episodes recorded with `robolab eval --record` (cameras with
`--record-images`) as a LeRobot dataset in LeRobot's v3.0 layout, so rollouts can be used as training data.

    OUT/meta/info.json                                  codebase_version "v3.0", fps 15, features, path templates
    OUT/meta/stats.json                                 per feature: min, max, mean, std, count, q01 q10 q50 q90 q99
    OUT/meta/tasks.parquet                              one row per instruction: index `task`, column `task_index`
    OUT/meta/episodes/chunk-000/file-000.parquet        one row per episode: length, tasks, where its frames and
                                                        video segments are, per-episode stats, success, score, ...
    OUT/data/chunk-000/file-000.parquet                 one row per frame (control step)
    OUT/videos/observation.images.<camera>/chunk-000/file-000.mp4   one video per camera, episodes one after another

A frame t of an episode with T steps holds what the policy saw before action t and that action: `observation.state`
= the 7 arm joint positions (rad) and the gripper's closed fraction (0 open .. 1 closed), DROID's proprioception;
`action` = the 8-D DROID action sent; `timestamp` = t / 15 s; `next.done` true on the last frame; `next.success`
the task's success after the action. The recording's final observation (row T) has no action and is left out.
Each data file and each camera video holds whole episodes, at most `frames_per_file` frames (one hour at 15 fps by
default); the episode's row says which file and, for videos, `from_timestamp` / `to_timestamp` of its segment.
Videos are H.264 (yuv420p) at 15 fps, frame i of a file at i / 15 s.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robolab_ms.errors import ResultsError, RoboLabError, make_folder
from robolab_ms.eval.results import (
    InvalidValue,
    as_count,
    as_events,
    as_flag,
    as_integer,
    as_name,
    as_names,
    as_number,
    as_text,
    optional,
    shown,
)
from robolab_ms.tasks.spec import CONTROL_HZ

CODEBASE_VERSION = "v3.0"
CHUNKS_SIZE = 1000  # files per chunk folder
DATA_FILES_SIZE_IN_MB = 100
VIDEO_FILES_SIZE_IN_MB = 200
FRAMES_PER_FILE = CONTROL_HZ * 3600  # frames of one data file / one camera video file (one hour at 15 fps)
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
TASKS_PATH = "meta/tasks.parquet"
INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)
IMAGE_STAT_FRAMES = 100  # frames per episode sampled for image statistics
IMAGE_STAT_WIDTH = 160  # sampled frames are thinned to about this width
VIDEO_CODEC = "h264"
RECORDING_FIX = (
    "Record the episode again, or move this recording (its .h5 and .json) out of the folder to export the others"
)
# the fields of a recording's `robolab` block that the export reads, and what each must be (absent: its default)
META_KINDS = {
    "task": as_name, "instruction": optional(as_text), "instruction_variant": optional(as_text),
    "robot": optional(as_text), "policy": optional(as_text), "seed": as_integer, "control_hz": as_count,
    "cameras": optional(as_names), "arm_joints": optional(as_names), "success": optional(as_flag),
    "score": optional(as_number), "progress": optional(as_number), "events": optional(as_events),
    "error": optional(as_text),
}  # fmt: skip
# datasets of a recording's trajectory group that the export reads, with the rows each needs (T: actions)
TRAJECTORY_DATASETS = {
    "actions": "T",
    "success": "T",
    "robolab/joint_position": "T + 1",
    "obs/extra/gripper_position": "T + 1",
}


@dataclass
class ExportReport:
    """What `export_lerobot` wrote."""

    out_dir: Path
    episodes: int = 0
    frames: int = 0
    tasks: int = 0
    cameras: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)  # recordings left out, with the reason

    def line(self) -> str:
        cameras = ", ".join(self.cameras) if self.cameras else "none (record with --record-images for videos)"
        return (
            f"{self.episodes} episode(s), {self.frames} frame(s), {self.tasks} task(s), cameras: {cameras} -> "
            f"{self.out_dir}"
        )


@dataclass
class _Episode:
    recording: Path
    meta: dict[str, Any]

    @property
    def robolab(self) -> dict[str, Any]:
        return self.meta.get("robolab", {})


def _chunk_file(number: int) -> dict[str, int]:
    return {"chunk_index": number // CHUNKS_SIZE, "file_index": number % CHUNKS_SIZE}


def feature_stats(values: np.ndarray, axis: tuple[int, ...] | int = 0, keepdims: bool = False) -> dict[str, np.ndarray]:
    """LeRobot's statistics of one feature: min, max, mean, std, count and the quantiles q01 q10 q50 q90 q99, each an
    array (a scalar feature gives shape (1,))."""
    values = np.asarray(values, dtype=np.float64)
    stats = {
        "min": np.min(values, axis=axis, keepdims=keepdims),
        "max": np.max(values, axis=axis, keepdims=keepdims),
        "mean": np.mean(values, axis=axis, keepdims=keepdims),
        "std": np.std(values, axis=axis, keepdims=keepdims),
    }
    for q in QUANTILES:
        stats[f"q{int(round(q * 100)):02d}"] = np.quantile(values, q, axis=axis, keepdims=keepdims)
    stats = {key: np.atleast_1d(value) for key, value in stats.items()}
    stats["count"] = np.array([values.shape[0]])
    return stats


def _image_stats(frames: np.ndarray) -> dict[str, np.ndarray]:
    """Per-channel statistics of (N, H, W, 3) uint8 frames scaled to [0, 1], shaped (3, 1, 1) as LeRobot keeps them."""
    channels_first = np.transpose(frames, (0, 3, 1, 2)).astype(np.float64) / 255.0
    stats = feature_stats(channels_first, axis=(0, 2, 3), keepdims=True)
    return {key: (value if key == "count" else value[0]) for key, value in stats.items()}


def _sample_frames(frames: np.ndarray) -> np.ndarray:
    """At most IMAGE_STAT_FRAMES evenly spaced frames, thinned to about IMAGE_STAT_WIDTH pixels wide."""
    picks = np.unique(np.linspace(0, len(frames) - 1, min(len(frames), IMAGE_STAT_FRAMES)).round().astype(int))
    step = max(1, frames.shape[2] // IMAGE_STAT_WIDTH)
    return np.asarray(frames[picks][:, ::step, ::step])


def _jsonable(stats: dict[str, dict[str, np.ndarray]]) -> dict[str, dict[str, Any]]:
    return {name: {key: value.tolist() for key, value in feature.items()} for name, feature in stats.items()}


def _load_episodes(run_dir: Path, success_only: bool, tasks: list[str] | None, report: ExportReport) -> list[_Episode]:
    from robolab_ms.eval.recording import find_recordings

    episodes = []
    for recording in find_recordings(run_dir):
        meta = _recording_meta(recording.with_suffix(".json"))
        info = meta.get("robolab", {})
        name = recording.relative_to(run_dir).as_posix() if recording.is_relative_to(run_dir) else recording.name
        if "robolab" not in meta:
            report.skipped.append(f"{name}: not written by robolab eval --record")
        elif tasks and info.get("task") not in tasks:
            continue
        elif info.get("error"):
            report.skipped.append(f"{name}: the episode errored ({info['error']})")
        elif success_only and not info.get("success"):
            continue
        elif not meta.get("episodes") or not meta["episodes"][0].get("elapsed_steps"):
            report.skipped.append(f"{name}: no steps")
        else:
            episodes.append(_Episode(recording, meta))
    return episodes


def _recording_meta(path: Path) -> dict[str, Any]:
    """A recording's .json with the fields the export reads checked (META_KINDS, `episodes[0].elapsed_steps`);
    ResultsError naming the file and the field otherwise. A .json without a `robolab` block is returned as it is
    (the export skips it: not ours)."""
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ResultsError(path, None, "", f"cannot be read as JSON ({exc})", RECORDING_FIX) from None
    if not isinstance(meta, dict):
        raise ResultsError(
            path, None, "", f"is {shown(meta)}, not a recording description (a JSON object)", RECORDING_FIX
        )
    if "robolab" not in meta:
        return meta
    info, field = meta["robolab"], "robolab"
    try:
        if not isinstance(info, dict):
            raise InvalidValue(f"is {shown(info)}, expected an object")
        for key, kind in META_KINDS.items():
            field = f"robolab.{key}"
            if key in info:
                kind(info[key])
        field = "robolab.control_hz"
        if info.get("control_hz") == 0:
            raise InvalidValue(f"is 0, expected the control rate in Hz ({CONTROL_HZ})")
        field = "episodes"
        episodes = meta.get("episodes", [])
        if not isinstance(episodes, list) or not all(isinstance(item, dict) for item in episodes):
            raise InvalidValue(f"is {shown(episodes)}, expected a list of episode objects")
        if episodes and "elapsed_steps" in episodes[0]:
            field = "episodes[0].elapsed_steps"
            as_count(episodes[0]["elapsed_steps"])
    except InvalidValue as exc:
        raise ResultsError(path, None, field, str(exc), RECORDING_FIX) from None
    return meta


def _open_trajectory(path: Path) -> Any:
    """The recording's HDF5 file, open for reading; ResultsError when it is not one."""
    import h5py

    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise ResultsError(path, None, "", f"is not a readable HDF5 file ({exc})", RECORDING_FIX) from None


def _read(episode: _Episode, cameras: list[str]) -> dict[str, np.ndarray]:
    """The arrays one episode contributes, T rows each (T = its number of actions)."""
    from robolab_ms.eval.recording import TRAJECTORY_KEY

    with _open_trajectory(episode.recording) as file:
        group = file.get(TRAJECTORY_KEY)
        for key in TRAJECTORY_DATASETS:
            if group is None or key not in group:
                raise ResultsError(episode.recording, None, f"{TRAJECTORY_KEY}/{key}", "is missing", RECORDING_FIX)
        steps = len(group["actions"])
        for key, rows in TRAJECTORY_DATASETS.items():
            needed = steps + (1 if rows == "T + 1" else 0)
            if len(group[key]) != needed:
                raise ResultsError(
                    episode.recording,
                    None,
                    f"{TRAJECTORY_KEY}/{key}",
                    f"has {len(group[key])} rows, expected {rows} = {needed} ({steps} actions)",
                    RECORDING_FIX,
                )
        actions = np.asarray(group["actions"], dtype=np.float32)
        steps = len(actions)
        joints = np.asarray(group["robolab/joint_position"][:steps], dtype=np.float32)
        gripper = np.asarray(group["obs/extra/gripper_position"][:steps], dtype=np.float32).reshape(steps, -1)
        arrays = {
            "observation.state": np.concatenate([joints, gripper[:, :1]], axis=1),
            "action": actions,
            "next.success": np.asarray(group["success"], dtype=bool).reshape(steps),
        }
        for camera in cameras:
            key = f"obs/sensor_data/{camera}/rgb"
            if key not in group:
                raise RoboLabError(
                    f"{episode.recording}: no images of the camera '{camera}' (recorded without "
                    "--record-images?); export recordings made the same way together, or pass "
                    "--no-videos"
                )
            arrays[f"observation.images.{camera}"] = np.asarray(group[key][:steps])
    return arrays


def _video_writer(path: Path, fps: int) -> Any:
    import imageio.v2 as imageio

    path.parent.mkdir(parents=True, exist_ok=True)
    return imageio.get_writer(
        path,
        format="FFMPEG",
        fps=fps,
        codec="libx264",
        pixelformat="yuv420p",
        quality=None,
        macro_block_size=1,
        ffmpeg_log_level="error",
        output_params=["-crf", "18", "-g", str(fps)],
    )


def export_lerobot(
    run_dir: Path,
    out_dir: Path,
    success_only: bool = False,
    tasks: list[str] | None = None,
    videos: bool = True,
    frames_per_file: int = FRAMES_PER_FILE,
) -> ExportReport:
    """Write the recordings of `run_dir` (a results folder, or a folder of recordings) as a LeRobot v3.0 dataset in
    `out_dir`, which must be empty or new. `success_only` keeps only successful episodes; `tasks` only those
    tasks; `videos=False` leaves the cameras out."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    run_dir, out_dir = Path(run_dir), Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise RoboLabError(f"{out_dir} is a file; give a new folder for the dataset")
    if out_dir.exists() and any(out_dir.iterdir()):
        raise RoboLabError(f"{out_dir} is not empty; give a new folder for the dataset")
    if frames_per_file < 1:
        raise RoboLabError(f"frames per file must be at least 1, got {frames_per_file}")
    report = ExportReport(out_dir=out_dir)
    episodes = _load_episodes(run_dir, success_only, tasks, report)
    if not episodes:
        why = "; ".join(report.skipped) or ("no successful episode" if success_only else "no recording")
        raise RoboLabError(
            f"{run_dir}: nothing to export ({why}). Record episodes with `robolab eval --record` "
            "(--record-images for camera videos)"
        )

    first = episodes[0].robolab
    fps = int(first.get("control_hz", CONTROL_HZ))
    arm_joints = list(first.get("arm_joints") or [f"joint_{i}" for i in range(7)])
    robot = first.get("robot")
    cameras = list(first.get("cameras") or []) if videos else []
    from robolab_ms.eval.recording import TRAJECTORY_KEY

    with _open_trajectory(episodes[0].recording) as file:
        cameras = [c for c in cameras if f"{TRAJECTORY_KEY}/obs/sensor_data/{c}/rgb" in file]
        shapes = {c: tuple(file[f"{TRAJECTORY_KEY}/obs/sensor_data/{c}/rgb"].shape[1:]) for c in cameras}
    for episode in episodes:
        info = episode.robolab
        if info.get("robot") != robot or int(info.get("control_hz", CONTROL_HZ)) != fps:
            raise RoboLabError(
                f"{episode.recording}: robot {info.get('robot')} at {info.get('control_hz')} Hz, but "
                f"{episodes[0].recording} has {robot} at {fps} Hz; export one robot per dataset "
                "(use --task, or separate results folders)"
            )

    task_texts = sorted({episode.robolab.get("instruction") or episode.robolab.get("task") for episode in episodes})
    task_index = {text: index for index, text in enumerate(task_texts)}
    video_keys = [f"observation.images.{camera}" for camera in cameras]
    features: dict[str, dict[str, Any]] = {
        "observation.state": {"dtype": "float32", "shape": [len(arm_joints) + 1], "names": [*arm_joints, "gripper"]},
        "action": {"dtype": "float32", "shape": [len(arm_joints) + 1], "names": [*arm_joints, "gripper"]},
    }
    for camera, key in zip(cameras, video_keys):
        height, width, channels = shapes[camera]
        if height % 2 or width % 2:
            raise RoboLabError(f"camera '{camera}' records {width}x{height} images; H.264 needs even sizes")
        features[key] = {
            "dtype": "video",
            "shape": [height, width, channels],
            "names": ["height", "width", "channels"],
            "info": {
                "video.height": height,
                "video.width": width,
                "video.codec": VIDEO_CODEC,
                "video.pix_fmt": "yuv420p",
                "video.is_depth_map": False,
                "video.fps": fps,
                "video.channels": channels,
                "has_audio": False,
            },
        }
    for name, dtype in (
        ("timestamp", "float32"),
        ("frame_index", "int64"),
        ("episode_index", "int64"),
        ("index", "int64"),
        ("task_index", "int64"),
        ("next.done", "bool"),
        ("next.success", "bool"),
    ):
        features[name] = {"dtype": dtype, "shape": [1], "names": None}

    dims = len(arm_joints) + 1
    schema = pa.schema(
        [
            ("observation.state", pa.list_(pa.float32(), dims)),
            ("action", pa.list_(pa.float32(), dims)),
            ("timestamp", pa.float32()),
            ("frame_index", pa.int64()),
            ("episode_index", pa.int64()),
            ("index", pa.int64()),
            ("task_index", pa.int64()),
            ("next.done", pa.bool_()),
            ("next.success", pa.bool_()),
        ]
    )
    make_folder(out_dir, "OUT_DIR")
    rows: list[dict[str, Any]] = []
    numeric: dict[str, list[np.ndarray]] = {name: [] for name in features if features[name]["dtype"] != "video"}
    samples: dict[str, list[np.ndarray]] = {key: [] for key in video_keys}
    file_number, file_frames, total = 0, 0, 0
    writer: Any = None
    video_writers: dict[str, Any] = {}
    try:
        for episode_index, episode in enumerate(episodes):
            arrays = _read(episode, cameras)
            steps = len(arrays["action"])
            if writer is not None and file_frames + steps > frames_per_file:  # the next file, for data and videos
                writer.close()
                for video in video_writers.values():
                    video.close()
                writer, video_writers, file_frames = None, {}, 0
                file_number += 1
            place = _chunk_file(file_number)
            if writer is None:
                path = out_dir / DATA_PATH.format(**place)
                path.parent.mkdir(parents=True, exist_ok=True)
                writer = pq.ParquetWriter(path, schema)
                video_writers = {
                    key: _video_writer(out_dir / VIDEO_PATH.format(video_key=key, **place), fps) for key in video_keys
                }
            frame = np.arange(steps)
            instruction = episode.robolab.get("instruction") or episode.robolab.get("task")
            columns = {
                "observation.state": arrays["observation.state"],
                "action": arrays["action"],
                "timestamp": (frame / fps).astype(np.float32),
                "frame_index": frame.astype(np.int64),
                "episode_index": np.full(steps, episode_index, np.int64),
                "index": np.arange(total, total + steps, dtype=np.int64),
                "task_index": np.full(steps, task_index[instruction], np.int64),
                "next.done": frame == steps - 1,
                "next.success": arrays["next.success"],
            }
            table = pa.table(
                {
                    name: (
                        pa.FixedSizeListArray.from_arrays(pa.array(columns[name].reshape(-1), pa.float32()), dims)
                        if name in ("observation.state", "action")
                        else pa.array(columns[name], schema.field(name).type)
                    )
                    for name in schema.names
                },
                schema=schema,
            )
            writer.write_table(table)
            episode_stats = {}
            for name in numeric:
                values = columns[name].astype(np.float64)
                numeric[name].append(values)
                episode_stats[name] = feature_stats(values if values.ndim > 1 else values.reshape(-1, 1))
            row: dict[str, Any] = {
                "episode_index": episode_index,
                "tasks": [instruction],
                "length": steps,
                "data/chunk_index": place["chunk_index"],
                "data/file_index": place["file_index"],
                "dataset_from_index": total,
                "dataset_to_index": total + steps,
            }
            for key in video_keys:
                frames = arrays[key]
                for image in frames:
                    video_writers[key].append_data(np.ascontiguousarray(image[..., :3]))
                sampled = _sample_frames(frames)
                samples[key].append(sampled)
                episode_stats[key] = _image_stats(sampled)
                row[f"videos/{key}/chunk_index"] = place["chunk_index"]
                row[f"videos/{key}/file_index"] = place["file_index"]
                row[f"videos/{key}/from_timestamp"] = file_frames / fps
                row[f"videos/{key}/to_timestamp"] = (file_frames + steps) / fps
            row["meta/episodes/chunk_index"], row["meta/episodes/file_index"] = 0, 0
            for name, stats in episode_stats.items():
                for key, value in stats.items():
                    row[f"stats/{name}/{key}"] = value.tolist()
            info = episode.robolab
            row.update(
                {
                    "success": bool(info.get("success")),
                    "score": float(info.get("score") or 0.0),
                    "progress": float(info.get("progress") or 0.0),
                    "seed": int(info.get("seed", -1)),
                    "robolab/task": info.get("task"),
                    "robolab/instruction_variant": info.get("instruction_variant"),
                    "robolab/robot": info.get("robot"),
                    "robolab/policy": info.get("policy"),
                    "robolab/events": json.dumps(info.get("events") or []),
                    "robolab/recording": episode.recording.name,
                }
            )
            rows.append(row)
            total += steps
            file_frames += steps
    finally:
        if writer is not None:
            writer.close()
        for video in video_writers.values():
            video.close()

    import pandas as pd

    episodes_path = out_dir / EPISODES_PATH.format(chunk_index=0, file_index=0)
    episodes_path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.Table.from_pylist(rows), episodes_path)
    tasks_frame = pd.DataFrame(
        {"task_index": np.arange(len(task_texts), dtype=np.int64)}, index=pd.Index(task_texts, name="task")
    )
    tasks_frame.to_parquet(out_dir / TASKS_PATH)

    stats = {}
    for name, parts in numeric.items():
        values = np.concatenate(parts)
        stats[name] = feature_stats(values if values.ndim > 1 else values.reshape(-1, 1))
    for key, parts in samples.items():
        stats[key] = _image_stats(np.concatenate(parts))
    (out_dir / STATS_PATH).write_text(json.dumps(_jsonable(stats), indent=2), encoding="utf-8")
    info_json = {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot,
        "total_episodes": len(rows),
        "total_frames": total,
        "total_tasks": len(task_texts),
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILES_SIZE_IN_MB,
        "video_files_size_in_mb": VIDEO_FILES_SIZE_IN_MB,
        "fps": fps,
        "splits": {"train": f"0:{len(rows)}"},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if video_keys else None,
        "features": features,
    }
    (out_dir / INFO_PATH).write_text(json.dumps(info_json, indent=4), encoding="utf-8")
    report.episodes, report.frames, report.tasks, report.cameras = len(rows), total, len(task_texts), video_keys
    return report
