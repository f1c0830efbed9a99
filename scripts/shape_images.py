"""Render the before / after pictures of task targets with a real shape (docs/fidelity.md, "Modelled objects"): each
task's scene at seed 0 through DROID's external-left and wrist cameras at 320x180 (a policy's resolution), and a
contact sheet that sets the two looks side by side.

    .venv/bin/python scripts/shape_images.py --tag after
    before=$(mktemp -d) && git archive 75758d3 | tar -x -C "$before"
    PYTHONPATH="$before" .venv/bin/python scripts/shape_images.py --tag before   # the catalog before the change
    .venv/bin/python scripts/shape_images.py --sheet

The frames go to --out (default results/shape_images) as TASK_CAMERA_TAG.png; the sheet is
docs/images/fidelity/modelled_objects.png.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

TASKS = {  # a task whose scene holds objects with a real shape, and which ones
    "BananaInBowl": "banana (envpool model), red bowl",
    "MarkerInMug": "blue mug (LIBERO model; left, behind the keyboard)",
    "RedDishesInBin": "red mug (LIBERO model), red bowl, banana",
    "FoodPackingByColor": "coffee can, soup can (HOPE scan); cracker, sugar, pudding boxes; flat mustard bottle",
    "FoodPacking2Boxes": "cracker, sugar boxes; soup can (HOPE scan), tuna can",
    "RecycleCarton": "milk, juice cartons (HOPE scans); white mug (envpool model)",
    "MustardAboveRaisin": "mustard bottle, raisin box",
    "PlasticBottlesInSquarePail": "small white packer bottle",
    "DishesInBin": "white mugs (LIBERO model), bananas, red bowl, Rubik's cubes",
    "FruitsOnPlate": "lemons, limes, oranges, pomegranate, red onion, white bowl",
}
CAMERAS = ("external_left", "wrist")
ROOT = Path(__file__).resolve().parents[1]


def render(task: str, out: Path, tag: str, width: int, height: int) -> None:
    from robolab_ms.envs import RoboLabEnv

    env = RoboLabEnv(task=task, obs_mode="rgb", render_backend="cpu", camera_width=width, camera_height=height)
    try:
        observation, _ = env.reset(seed=0)
        for camera in CAMERAS:
            image = observation["sensor_data"][camera]["rgb"][0].cpu().numpy()
            Image.fromarray(image).save(out / f"{task}_{camera}_{tag}.png", optimize=True)
    finally:
        env.close()


def sheet(frames: Path, out: Path, width: int, height: int) -> None:
    """One row per task: external left before, after; wrist before, after; a label above each row."""
    label = 16
    columns = [(camera, tag) for camera in CAMERAS for tag in ("before", "after")]
    image = Image.new("RGB", (len(columns) * width, len(TASKS) * (height + label) + label), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default()
    for column, (camera, tag) in enumerate(columns):
        draw.text((column * width + 4, 2), f"{camera.replace('_', ' ')}, {tag}", fill=(0, 0, 0), font=font)
    for row, (task, what) in enumerate(TASKS.items()):
        top = label + row * (height + label)
        draw.text((4, top + 2), f"{task}: {what}", fill=(0, 0, 0), font=font)
        for column, (camera, tag) in enumerate(columns):
            frame = frames / f"{task}_{camera}_{tag}.png"
            picture = Image.open(frame).convert("RGB") if frame.is_file() else Image.new("RGB", (width, height))
            image.paste(picture.resize((width, height)), (column * width, top + label))
    image.save(out, optimize=True)
    print(f"contact sheet: {out} ({np.asarray(image).shape[1]}x{np.asarray(image).shape[0]})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tag", choices=["before", "after"], help="render the frames under this tag")
    parser.add_argument("--sheet", action="store_true", help="compose the contact sheet from the frames")
    parser.add_argument("--tasks", nargs="+", default=list(TASKS))
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "shape_images")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=180)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if args.tag:
        for task in args.tasks:
            render(task, args.out, args.tag, args.width, args.height)
            print(task, flush=True)
    if args.sheet:
        sheet(args.out, ROOT / "docs" / "images" / "fidelity" / "modelled_objects.png", args.width, args.height)


if __name__ == "__main__":
    main()
