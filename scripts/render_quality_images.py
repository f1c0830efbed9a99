"""Ray-traced against rasterised pictures (docs/fidelity.md, "Render quality"): each task's scene at seed 0 through
DROID's external-left and wrist cameras, once with `render_quality="fast"` (the rasteriser) and once with "high"
(SAPIEN's ray tracer, 32 samples per pixel), and a sheet that sets them side by side.

    .venv/bin/python scripts/render_quality_images.py --tasks BananaInBowl RecycleCarton
    .venv/bin/python scripts/render_quality_images.py --sheet

On a GPU the ray tracer's frames are denoised; on a CPU (lavapipe) the denoiser needs CUDA and does not start, so
the frames show the path tracer's raw noise, and each one takes minutes. The frames go to --out (default
results/render_quality) as TASK_CAMERA_QUALITY.png; the sheet is docs/images/fidelity/render_quality.png.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from PIL import Image, ImageDraw, ImageFont

CAMERAS = ("external_left", "wrist")
QUALITIES = ("fast", "high")
ROOT = Path(__file__).resolve().parents[1]
SHEET = ROOT / "docs" / "images" / "fidelity" / "render_quality.png"


def render(task: str, quality: str, out: Path, width: int, height: int) -> float:
    """Write the task's frames at seed 0 in one render quality; the seconds the reset took (the scene's build and
    the cameras' render)."""
    from robolab_ms.envs import RoboLabEnv

    env = RoboLabEnv(
        task=task,
        obs_mode="rgb",
        render_backend="cpu",
        camera_width=width,
        camera_height=height,
        render_quality=quality,
    )
    try:
        start = time.perf_counter()
        observation, _ = env.reset(seed=0)
        seconds = time.perf_counter() - start
        for camera in CAMERAS:
            image = observation["sensor_data"][camera]["rgb"][0].cpu().numpy()
            Image.fromarray(image).save(out / f"{task}_{camera}_{quality}.png", optimize=True)
    finally:
        env.close()
    return seconds


def sheet(frames: Path, tasks: list[str], width: int, height: int) -> None:
    """One row per task: external left fast, high; wrist fast, high."""
    label = 16
    columns = [(camera, quality) for camera in CAMERAS for quality in QUALITIES]
    names = {"fast": "rasterised", "high": "ray traced"}
    image = Image.new("RGB", (len(columns) * width, len(tasks) * (height + label) + label), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default()
    for column, (camera, quality) in enumerate(columns):
        draw.text((column * width + 4, 2), f"{camera.replace('_', ' ')}, {names[quality]}", fill=(0, 0, 0), font=font)
    for row, task in enumerate(tasks):
        top = label + row * (height + label)
        draw.text((4, top + 2), task, fill=(0, 0, 0), font=font)
        for column, (camera, quality) in enumerate(columns):
            frame = frames / f"{task}_{camera}_{quality}.png"
            picture = Image.open(frame).convert("RGB") if frame.is_file() else Image.new("RGB", (width, height))
            image.paste(picture.resize((width, height)), (column * width, top + label))
    SHEET.parent.mkdir(parents=True, exist_ok=True)
    image.save(SHEET, optimize=True)
    print(f"sheet: {SHEET} ({image.width}x{image.height})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", nargs="+", default=["BananaInBowl", "RecycleCarton"])
    parser.add_argument("--qualities", nargs="+", choices=QUALITIES, default=list(QUALITIES))
    parser.add_argument("--sheet", action="store_true", help="compose the sheet from the frames already rendered")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "render_quality")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=180)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if args.sheet:
        sheet(args.out, args.tasks, args.width, args.height)
        return
    for task in args.tasks:
        for quality in args.qualities:
            seconds = render(task, quality, args.out, args.width, args.height)
            print(f"{task} {quality}: reset and render {seconds:.1f} s at {args.width}x{args.height}", flush=True)


if __name__ == "__main__":
    main()
