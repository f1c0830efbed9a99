"""Render every scene from the external-left camera (640x360) and a contact sheet of them all.

    PYTHONPATH=. python scripts/scene_gallery.py [--out docs/images/scenes] [--scenes NAME ...]

Writes OUT/<scene>.png for each scene file and OUT/contact_sheet.png (a labelled grid of all of them), so the scenes
can be compared with RoboLab's. Each scene is shown at its nominal layout (seed 0), with the robot at home.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import gymnasium as gym
import numpy as np
from PIL import Image, ImageDraw

WIDTH, HEIGHT = 640, 360
SHEET_COLUMNS = 4
SHEET_TILE = (240, 135)
LABEL_HEIGHT = 18

PROBE_TASK = """name: {name}
scene: {scene}
episode_seconds: 1
attributes: []
instructions: {{default: look, vague: look, specific: look}}
success:
  - {{predicate: picked_up, objects: [{obj}]}}
"""


def render_scene(scene: str, folder: Path) -> Image.Image:
    """The external-left camera's view of `scene` after a reset with seed 0."""
    import robolab_ms.envs  # noqa: F401  (registers the environments)
    from robolab_ms.envs import register_task_file
    from robolab_ms.scene import load_scene

    spec = load_scene(scene)
    name = "Gallery" + "".join(part.title() for part in scene.split("_"))
    path = folder / f"{name}.yaml"
    path.write_text(PROBE_TASK.format(name=name, scene=scene, obj=spec.objects[0].name))
    env = gym.make(
        register_task_file(path, replace=True),
        task=str(path),
        obs_mode="rgb",
        cameras=("external_left",),
        camera_width=WIDTH,
        camera_height=HEIGHT,
    )
    try:
        obs, _ = env.reset(seed=0)
        rgb = obs["sensor_data"]["external_left"]["rgb"][0].cpu().numpy().astype(np.uint8)
    finally:
        env.close()
    return Image.fromarray(rgb)


def contact_sheet(images: dict[str, Image.Image]) -> Image.Image:
    """A grid of the scene images, each labelled with its scene's name."""
    rows = math.ceil(len(images) / SHEET_COLUMNS)
    tile_w, tile_h = SHEET_TILE
    sheet = Image.new("RGB", (SHEET_COLUMNS * tile_w, rows * (tile_h + LABEL_HEIGHT)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for index, (scene, image) in enumerate(sorted(images.items())):
        x, y = (index % SHEET_COLUMNS) * tile_w, (index // SHEET_COLUMNS) * (tile_h + LABEL_HEIGHT)
        sheet.paste(image.resize(SHEET_TILE, Image.LANCZOS), (x, y + LABEL_HEIGHT))
        draw.text((x + 4, y + 3), scene, fill=(0, 0, 0))
    return sheet


def save(image: Image.Image, path: Path, colors: int = 256) -> None:
    """A small PNG: the image reduced to a palette of `colors`, then compressed as far as PIL goes."""
    image.convert("RGB").quantize(colors=colors, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


def main(argv: list[str] | None = None) -> int:
    from robolab_ms.scene import scene_names

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="docs/images/scenes", help="output folder (default docs/images/scenes)")
    parser.add_argument(
        "--scenes", nargs="+", help="only these scenes (the contact sheet still shows every image in the output folder)"
    )
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as folder:
        for scene in args.scenes or scene_names():
            image = render_scene(scene, Path(folder))
            save(image, out / f"{scene}.png")
            print(f"{scene}: {out / f'{scene}.png'}")
    images = {
        path.stem: Image.open(path).convert("RGB") for path in sorted(out.glob("*.png")) if path.stem != "contact_sheet"
    }
    save(contact_sheet(images), out / "contact_sheet.png", colors=32)
    print(f"contact sheet: {out / 'contact_sheet.png'} ({len(images)} scenes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
