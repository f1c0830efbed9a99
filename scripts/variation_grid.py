"""A picture grid of the variation axes: one task seen by the external-left camera under the extremes of each axis.

    PYTHONPATH=. python scripts/variation_grid.py [--task PickUpGreenObject] [--out docs/images/variations.png]

One row per axis; the first picture of each row is the scene as its file says (no variations), the others are
fixed settings at the ends of the axis's range (or draws of it, for object poses, robot joints and distractors).
The grid is quantised to 256 colours to keep the file small.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
from PIL import Image, ImageDraw

RENDER = (320, 180)  # rendered, then shrunk to TILE for a smooth picture
TILE = (192, 108)
LABEL = 14
X, Z, R = 0.2, 0.1, 0.2  # RoboLab's external camera ranges

ROWS: list[tuple[str, list[tuple[str, str, int]]]] = [  # axis -> (label, settings, seed)
    ("lighting", [("dim", "lighting=dim", 0), ("bright", "lighting=bright", 0), ("red", "lighting=red", 0),
                  ("green", "lighting=green", 0), ("blue", "lighting=blue", 0), ("from the front", "lighting=front", 0),
                  ("from the left", "lighting=left", 0), ("dome low", "lighting=dome_low", 0)]),
    ("background", [(name, f"background={name}", 0) for name in ("night", "sky", "forest", "studio", "warehouse",
                                                                  "venice", "hall", "sunset")]),
    ("table", [(name, f"table={name}", 0) for name in ("dark_wood", "wood_planks", "bamboo", "black_matte",
                                                        "white_marble", "grey_tile", "brown_tile", "rustic")]),
    ("camera", [(f"{label}", f"camera.external_{key}={v}:{v}", 0) for label, key, v in (
        ("x, y -0.2 m", "xy", -X), ("x, y +0.2 m", "xy", X), ("z -0.1 m", "z", -Z), ("z +0.1 m", "z", Z),
        ("r, p, y -0.2 rad", "rot", -R), ("r, p, y +0.2 rad", "rot", R))]),
    ("objects", [(f"+-0.3 m, seed {seed}", "objects=0.3,objects.yaw=0.5", seed) for seed in range(4)]
     + [(f"+-0.1 m, seed {seed}", "objects=0.1", seed) for seed in range(2)]),
    ("robot", [(f"+-0.2 rad, seed {seed}", "robot=0.2", seed) for seed in range(4)]),
    ("noise", [("std 8", "noise=8", 0), ("std 16", "noise=16", 0), ("std 32", "noise=32", 0)]),
    ("distractors", [(f"seed {seed}", "distractors", seed) for seed in range(6)]),
]  # fmt: skip


def render(env, settings: str | None, seed: int) -> Image.Image:
    base = env.unwrapped
    base.set_variations(settings)
    obs, _ = env.reset(seed=seed)
    image = Image.fromarray(obs["sensor_data"]["external_left"]["rgb"][0].numpy())
    return image.resize(TILE, Image.LANCZOS)


def grid(task: str) -> Image.Image:
    """The full-colour grid for `task`."""
    import mani_skill.envs  # noqa: F401  (registers the RoboLab environments)

    env = gym.make(
        f"RoboLab-{task}-v1",
        obs_mode="rgb",
        render_backend="cpu",
        cameras=["external_left"],
        camera_width=RENDER[0],
        camera_height=RENDER[1],
    )
    columns = 1 + max(len(cells) for _, cells in ROWS)
    header = 18
    sheet = Image.new("RGB", (columns * TILE[0], header + len(ROWS) * (TILE[1] + LABEL)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    draw.text(
        (4, 3),
        f"{task}, external-left camera: the scene as its file says (first column), then each "
        "axis at the ends of its range",
        fill=(0, 0, 0),
    )
    plain = render(env, None, 0)
    for row, (axis, cells) in enumerate(ROWS):
        top = header + row * (TILE[1] + LABEL)
        for column, (label, settings, seed) in enumerate([("as the scene says", None, 0), *cells]):
            image = plain if settings is None else render(env, settings, seed)
            sheet.paste(image, (column * TILE[0], top + LABEL))
            text = f"{axis}: {label}" if column == 1 else label
            draw.text((column * TILE[0] + 3, top + 1), text, fill=(0, 0, 0))
            print(axis, label, env.unwrapped.variation_params if settings else {}, flush=True)
    env.close()
    return sheet


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="PickUpGreenObject")
    parser.add_argument("--out", default="docs/images/variations.png")
    args = parser.parse_args()
    sheet = grid(args.task)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    palette = sheet.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.FLOYDSTEINBERG)
    palette.save(out, optimize=True)
    print(f"{out}: {out.stat().st_size // 1024} KB, {sheet.size[0]}x{sheet.size[1]}")


if __name__ == "__main__":
    main()
