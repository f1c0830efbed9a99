"""Episode videos: the policy's camera views side by side above the wide video camera, with a caption band
(instruction, step, score, events), one mp4 per episode.

The simulation thread only hands over the rendered images (`EpisodeVideo.add`); laying out the frame, drawing the
text and encoding (an ffmpeg process fed by imageio) happen on a background thread, so an episode never waits for
the encoder unless more than `queue_frames` frames are pending. A file appears under its final name only when it is
complete: a video not ended before `close()` is dropped, and a killed process leaves at most a `*.partial.mp4`.
"""

from __future__ import annotations

import os
import queue
import textwrap
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from robolab_ms.tasks.spec import CONTROL_HZ

VIDEO_WIDTH = 640  # frame width; the policy views share it, the video camera is scaled to it
CAPTION_LINES = 5  # instruction (up to 2 lines), status line, up to 2 event lines
LINE_HEIGHT = 18
FONT = cv2.FONT_HERSHEY_SIMPLEX
FONT_SCALE = 0.45
TEXT = (235, 235, 235)
SUCCESS_COLOUR = (80, 220, 80)
EVENT_COLOUR = (255, 170, 60)
SHOWN_EVENTS = 4  # the latest events drawn on a frame


@dataclass(frozen=True)
class Caption:
    """What is written on one frame."""

    instruction: str
    step: int
    max_steps: int
    score: float = 0.0
    success: bool = False
    events: Sequence[Mapping[str, Any]] = field(default_factory=tuple)  # every event so far: step, type, object


def _fit(image: np.ndarray, width: int) -> np.ndarray:
    """Scale an (H, W, 3) image to `width`, keeping its aspect ratio; height rounded to an even number."""
    height = max(2, int(round(image.shape[0] * width / image.shape[1] / 2)) * 2)
    if image.shape[1] == width and image.shape[0] == height:
        return image
    return cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)


def _rgb_uint8(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim == 4:  # a batch of one
        image = image[0]
    if image.dtype != np.uint8:
        image = np.clip(image * (255.0 if image.max() <= 1.0 else 1.0), 0, 255).astype(np.uint8)
    return np.ascontiguousarray(image[..., :3])


def compose_frame(
    policy_views: Mapping[str, np.ndarray], video_view: np.ndarray | None, caption: Caption, width: int = VIDEO_WIDTH
) -> np.ndarray:
    """One video frame (H, width, 3) uint8: policy views in a row, the video camera below, the caption band last.

    The height is padded to a multiple of 16 (what H.264 encoders want)."""
    rows = []
    views = [_rgb_uint8(view) for view in policy_views.values()]
    if views:
        share = width // len(views)
        scaled = [_fit(view, share) for view in views]
        tallest = max(view.shape[0] for view in scaled)
        row = np.zeros((tallest, width, 3), dtype=np.uint8)
        for index, view in enumerate(scaled):
            row[: view.shape[0], index * share : index * share + share] = view
        for index, name in enumerate(policy_views):
            cv2.putText(row, name, (index * share + 4, 14), FONT, 0.4, (0, 0, 0), 3, cv2.LINE_AA)
            cv2.putText(row, name, (index * share + 4, 14), FONT, 0.4, TEXT, 1, cv2.LINE_AA)
        rows.append(row)
    if video_view is not None:
        rows.append(_fit(_rgb_uint8(video_view), width))
    band_height = CAPTION_LINES * LINE_HEIGHT + 6
    body = sum(row.shape[0] for row in rows)
    band_height += (-(body + band_height)) % 16
    band = np.full((band_height, width, 3), 24, dtype=np.uint8)
    _draw_caption(band, caption, width)
    rows.append(band)
    return np.concatenate(rows, axis=0)


def _draw_caption(band: np.ndarray, caption: Caption, width: int) -> None:
    chars = max(20, width // 8)
    lines: list[tuple[str, tuple[int, int, int]]] = [
        (line, TEXT) for line in textwrap.wrap(caption.instruction, chars)[:2]
    ]
    status = f"step {caption.step}/{caption.max_steps}   score {caption.score:.2f}"
    lines.append((status + ("   SUCCESS" if caption.success else ""), SUCCESS_COLOUR if caption.success else TEXT))
    recent = list(caption.events)[-SHOWN_EVENTS:]
    texts = [f"{e.get('step')}: {e.get('type')} ({e.get('object')})" for e in recent]
    for index in range(0, len(texts), 2):
        lines.append(("   ".join(texts[index : index + 2]), EVENT_COLOUR))
    for index, (text, colour) in enumerate(lines[:CAPTION_LINES]):
        cv2.putText(band, text, (6, 16 + index * LINE_HEIGHT), FONT, FONT_SCALE, colour, 1, cv2.LINE_AA)


_END, _STOP = "end", "stop"


class EpisodeVideo:
    """Writes one mp4 per episode on a background thread.

    Call `begin(path)` at each episode start, `add(...)` after reset and after each step, `end()` when the episode
    is over (the file is finished in the background), and `close()` once at the end of the run: it waits for every
    file and raises the first encoding error, if any. A video begun but not ended when `close()` comes is dropped.
    """

    def __init__(self, fps: int = CONTROL_HZ, width: int = VIDEO_WIDTH, queue_frames: int = 64) -> None:
        self.fps, self.width = fps, width
        self._queue: queue.Queue = queue.Queue(maxsize=queue_frames)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._work, name="robolab-video", daemon=True)
        self._thread.start()
        self.written: list[Path] = []

    def begin(self, path: Path) -> None:
        self._check()
        self._queue.put(("begin", Path(path)))

    def add(self, policy_views: Mapping[str, np.ndarray], video_view: np.ndarray | None, caption: Caption) -> None:
        """Queue one frame (images are copied to numpy here; everything else happens on the encoder thread)."""
        self._check()
        views = {name: np.array(view) for name, view in policy_views.items()}
        self._queue.put(("frame", (views, None if video_view is None else np.array(video_view), caption)))

    def end(self) -> None:
        self._queue.put((_END, None))

    def close(self) -> None:
        if self._thread.is_alive():
            self._queue.put((_STOP, None))
            self._thread.join()
        self._check()

    def _check(self) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise RuntimeError(f"video encoding failed: {error}") from error

    def _work(self) -> None:
        import imageio.v2 as imageio

        writer, path, partial = None, None, None
        while True:
            kind, payload = self._queue.get()
            try:
                if kind == "begin":
                    if writer is not None:  # the previous video was never ended
                        writer.close()
                        partial.unlink(missing_ok=True)
                    path = payload
                    path.parent.mkdir(parents=True, exist_ok=True)
                    partial = path.with_name(path.stem + ".partial.mp4")
                    writer = imageio.get_writer(
                        partial,
                        format="FFMPEG",
                        fps=self.fps,
                        codec="libx264",
                        quality=7,
                        macro_block_size=16,
                        ffmpeg_log_level="error",
                    )
                elif kind == "frame" and writer is not None:
                    writer.append_data(compose_frame(*payload, width=self.width))
                elif kind == _END and writer is not None:
                    writer.close()
                    writer = None
                    os.replace(partial, path)
                    self.written.append(path)
                elif kind == _STOP and writer is not None:  # stopped mid-episode: that video is not kept
                    writer.close()
                    writer = None
                    partial.unlink(missing_ok=True)
            except Exception as error:  # keep draining so the simulation thread never blocks on a dead encoder
                self._error = self._error or error
                if writer is not None:
                    try:
                        writer.close()
                    except Exception:
                        pass
                writer = None
            if kind == _STOP:
                return
