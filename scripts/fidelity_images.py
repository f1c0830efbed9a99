"""Render the before / after pictures of docs/fidelity.md: DROID's external-left and wrist cameras at 640x360.

    .venv/bin/python scripts/fidelity_images.py [--tasks BananaInBowl ...] [--out docs/images/fidelity]

`after` is the environment as it is. `before` rebuilds the look the scenes had before issue 18, on the same scenes
and seeds: ManiSkill's grid ground and black background, flat colours, ManiSkill's default lights without shadows.
"""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path

import sapien
from mani_skill.envs.sapien_env import BaseEnv
from PIL import Image

import robolab_ms.catalog.schema as catalog_schema
from robolab_ms.catalog.appearance import Look
from robolab_ms.envs import RoboLabEnv
from robolab_ms.scene import TABLE_HEIGHT
from robolab_ms.scene.builder import RoboLabSceneBuilder

TASKS = ["BananaInBowl", "BlocksInBin", "MouseOnKeyboard", "ReorientRedMug", "RubiksCubeBehindBowl"]
ROOT = Path(__file__).resolve().parents[1]


def flat(look, face: int = 0) -> sapien.render.RenderMaterial:
    return sapien.render.RenderMaterial(base_color=[*look.rgb, 1.0], roughness=0.6)


@contextlib.contextmanager
def old_look():
    """Patch the builder and the environment back to the pre-issue-18 look while the block runs."""
    from mani_skill.utils.building.ground import build_ground

    saved = (
        RoboLabSceneBuilder._build_floor,
        RoboLabSceneBuilder._build_backdrop,
        RoboLabSceneBuilder._table_render_material,
        RoboLabEnv._load_lighting,
        catalog_schema.render_material,
        RoboLabSceneBuilder.build,
    )
    original_build = RoboLabSceneBuilder.build

    def build(self, build_config_idxs=None):
        original_build(self, build_config_idxs)
        for sub_scene in self.scene.sub_scenes:
            sub_scene.render_system.cubemap = None

    RoboLabSceneBuilder._build_floor = lambda self: build_ground(self.scene, altitude=-TABLE_HEIGHT)
    RoboLabSceneBuilder._build_backdrop = lambda self: None
    RoboLabSceneBuilder._table_render_material = lambda self: flat(
        Look("plastic", tuple(self.spec.table_rgba[:3]), 0.8)
    )
    RoboLabSceneBuilder.build = build
    RoboLabEnv._load_lighting = BaseEnv._load_lighting
    catalog_schema.render_material = flat
    try:
        yield
    finally:
        (
            RoboLabSceneBuilder._build_floor,
            RoboLabSceneBuilder._build_backdrop,
            RoboLabSceneBuilder._table_render_material,
            RoboLabEnv._load_lighting,
            catalog_schema.render_material,
            RoboLabSceneBuilder.build,
        ) = saved


def render(task: str, out: Path, tag: str, width: int, height: int) -> None:
    env = RoboLabEnv(task=task, obs_mode="rgb", render_backend="cpu", camera_width=width, camera_height=height)
    try:
        observation, _ = env.reset(seed=0)
        for camera in ("external_left", "wrist"):
            image = observation["sensor_data"][camera]["rgb"][0].cpu().numpy()
            Image.fromarray(image).save(out / f"{task}_{camera}_{tag}.png", optimize=True)
    finally:
        env.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", nargs="+", default=TASKS)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images" / "fidelity")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=360)
    parser.add_argument("--only", choices=["before", "after"], default=None)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for task in args.tasks:
        if args.only != "before":
            render(task, args.out, "after", args.width, args.height)
        if args.only != "after":
            with old_look():
                render(task, args.out, "before", args.width, args.height)
        print(task, flush=True)


if __name__ == "__main__":
    main()
