"""What `--video` costs the simulation thread per frame: handing images to the background encoder
(`EpisodeVideo.add`) against laying out, captioning and encoding the frame in place, in one process.

Frames are synthetic (two 320x180 policy views and a 640x360 video view with moving shapes on a gradient), so
rendering, which `--video` needs in either case, is not part of the comparison. The script prints milliseconds per
frame for both and their ratio; the hand-off should cost a small fraction of encoding in place.

    .venv/bin/python benchmarks/video_cost.py [--frames 150] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np

from robolab_ms.eval.video import Caption, EpisodeVideo, compose_frame


def synthetic_views(index: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
    def view(width: int, height: int, phase: float) -> np.ndarray:
        x = np.linspace(0, 255, width, dtype=np.float32)
        image = np.repeat(np.repeat(x[None, :, None], height, 0), 3, 2).astype(np.uint8)
        centre = (int(width / 2 + width / 3 * np.sin(phase)), int(height / 2 + height / 4 * np.cos(phase)))
        cv2.circle(image, centre, height // 6, (220, 40, 40), -1)
        cv2.rectangle(image, (width // 5, height // 2), (width // 5 + 40, height // 2 + 25), (40, 160, 220), -1)
        return image

    phase = index * 0.1
    return {"external_left": view(320, 180, phase), "wrist": view(320, 180, -phase)}, view(640, 360, 2 * phase)


def caption(index: int) -> Caption:
    events = [{"step": s, "type": "gripper_hit_table", "object": "table"} for s in range(0, index, 40)]
    return Caption("Put the banana in the bowl.", index, 900, 0.25, False, events)


def in_place(frames: int, folder: Path) -> float:
    """Seconds per frame when the simulation thread composes and encodes each frame itself."""
    writer = imageio.get_writer(
        folder / "inline.mp4",
        format="FFMPEG",
        fps=15,
        codec="libx264",
        quality=7,
        macro_block_size=16,
        ffmpeg_log_level="error",
    )
    data = [synthetic_views(i) for i in range(frames)]
    start = time.perf_counter()
    for index, (views, video) in enumerate(data):
        writer.append_data(compose_frame(views, video, caption(index)))
    writer.close()
    return (time.perf_counter() - start) / frames


def handed_off(frames: int, folder: Path) -> float:
    """Seconds per frame the simulation thread spends in `EpisodeVideo.add` (encoding continues behind it)."""
    encoder = EpisodeVideo(queue_frames=frames + 1)
    data = [synthetic_views(i) for i in range(frames)]
    encoder.begin(folder / "background.mp4")
    start = time.perf_counter()
    for index, (views, video) in enumerate(data):
        encoder.add(views, video, caption(index))
    spent = time.perf_counter() - start
    encoder.end()
    encoder.close()
    assert (folder / "background.mp4").exists()
    return spent / frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=150)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.frames, args.rounds = 4, 1
    inline, background = [], []
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(args.rounds):
            inline.append(in_place(args.frames, Path(folder)))
            background.append(handed_off(args.frames, Path(folder)))
    inline_ms, background_ms = statistics.median(inline) * 1e3, statistics.median(background) * 1e3
    print(f"compose + encode in place: {inline_ms:.2f} ms/frame")
    print(f"hand-off to the encoder thread: {background_ms:.3f} ms/frame")
    print(f"ratio (hand-off / in place): {background_ms / inline_ms:.3f}")


if __name__ == "__main__":
    main()
