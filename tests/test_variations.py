"""Domain randomization (robolab_ms.variations): every axis changes the images or the state it should and stays
within its range; the same seed gives the same parameters and images in a fresh or a reused environment; no
variations leaves the environment exactly as it was; suites list and run, and result lines carry the parameters.

One environment of RubiksCubeBehindBowl (a spatial task, so object poses can solve it by chance; the banana is a
distractor) with 64x36 cameras is reused; `set_variations` changes its settings between resets.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import mani_skill.envs  # noqa: F401  (registers the RoboLab environments)
import numpy as np
import pytest
import torch

from robolab_ms.catalog import COLOR_NAMES, load_catalog
from robolab_ms.envs import cameras
from robolab_ms.eval.results import EpisodeResult, read_results
from robolab_ms.tasks.spec import load_task
from robolab_ms.variations import AXES, Context, VariationError, Variations, suite_conditions, suites
from robolab_ms.variations.distractors import task_colours
from robolab_ms.variations.lighting import ENVIRONMENT_LEVELS, LIGHT_COLORS, LIGHT_DIRECTIONS

TASK = "RubiksCubeBehindBowl"
ALL_AXES = "lighting,background,table,camera,objects,robot,noise,distractors"
SIZE = dict(camera_width=64, camera_height=36)
ROBOLAB = str(Path(sys.executable).with_name("robolab"))


def make(**kwargs):
    return gym.make(f"RoboLab-{TASK}-v1", obs_mode="rgb", render_backend="cpu", **SIZE, **kwargs)


@pytest.fixture(scope="module")
def env():
    env = make()
    yield env
    env.close()


def observe(env, settings, seed: int = 0) -> dict:
    """Reset under `settings`: the drawn fields, the policy cameras' images, object positions and arm joints."""
    base = env.unwrapped
    base.set_variations(settings)
    obs, info = env.reset(seed=seed)
    return {
        "fields": base.variation_params,
        "images": {name: obs["sensor_data"][name]["rgb"][0].numpy().copy() for name in base.camera_names},
        "positions": {name: actor.pose.p[0].clone() for name, actor in base.objects.items()},
        "arm": base.arm_qpos()[0].clone(),
        "success": bool(info["success"][0]),
    }


def brightness(image: np.ndarray) -> float:
    return float(image.astype(float).mean())


def gap(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between two convex polygons (K, 2), counter-clockwise; negative when they overlap."""

    def inside(point, polygon):
        edges = np.roll(polygon, -1, axis=0) - polygon
        return bool((edges[:, 0] * (point[1] - polygon[:, 1]) - edges[:, 1] * (point[0] - polygon[:, 0]) >= 0).all())

    def point_to_edges(point, polygon):
        start, end = polygon, np.roll(polygon, -1, axis=0)
        t = np.clip(((point - start) * (end - start)).sum(1) / ((end - start) ** 2).sum(1), 0, 1)
        return float(np.linalg.norm(start + t[:, None] * (end - start) - point, axis=1).min())

    if any(inside(p, b) for p in a) or any(inside(p, a) for p in b):
        return -1.0
    return min(min(point_to_edges(p, b) for p in a), min(point_to_edges(p, a) for p in b))


# ------------------------------------------------------------------------------------------------ settings
def test_settings_from_text_and_dict():
    bare = Variations.create("lighting")
    assert bare.ranges()["lighting"]["intensity"] == [0.05, 3.0]
    assert set(bare.ranges()["lighting"]["color"]) == set(LIGHT_COLORS)
    dim = Variations.create("lighting=dim")  # a condition: the other parameters keep the scene's values
    assert dim.ranges()["lighting"] == {
        "intensity": [0.01, 0.01],
        "environment": [0.1, 0.1],
        "color": ["white"],
        "direction": ["key"],
        "ambient": [0.0, 0.0],
    }
    objects = Variations.create("objects=0.2")
    assert objects.ranges()["objects"] == {"xy": [-0.2, 0.2], "yaw": [0.0, 0.0], "names": "all"}
    mixed = Variations.create({"objects": 0.2, "lighting": {"intensity": [0.5, 2]}, "background": "city/park"})
    assert mixed.ranges()["lighting"]["intensity"] == [0.5, 2.0]
    assert mixed.ranges()["background"]["name"] == ["city", "park"]
    assert mixed.text == "objects=0.2,lighting.intensity=0.5:2,background=city/park"
    assert Variations.create(mixed.text).ranges() == mixed.ranges()
    later = Variations.create("camera=external").combined("camera.external_rot=0.1")
    assert later.ranges()["camera"]["external_rot"] == [-0.1, 0.1]
    assert later.ranges()["camera"]["external_xy"] == [-0.2, 0.2]
    assert not Variations.create(None) and not Variations.create("") and not Variations.create({})


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("lightning", ["unknown axis 'lightning'", "Did you mean 'lighting'"]),
        ("lighting.intensty=2", ["'intensty' is not a parameter of lighting", "'intensity'"]),
        ("lighting=candle", ["lighting takes a condition", "dim", "lighting.PARAM=VALUE"]),
        ("objects=far", ["expected a number (0.2) or a range (0.1:0.3)", "'far'"]),
        ("objects.xy=0.3:0.1", ["is empty", "LOW <= HIGH"]),
        ("objects=0.9", ["must stay within -0.5..0.5 m"]),
        ("background=citty", ["'citty' is not one of the background names", "Did you mean 'city'"]),
        ("table=", ["no value after '='"]),
    ],
)
def test_bad_settings_say_what_and_how_to_fix(text, words):
    with pytest.raises(VariationError) as error:
        Variations.create(text)
    for word in words:
        assert word in str(error.value), str(error.value)
    assert text.split(",")[0] in str(error.value)


def test_drawn_parameters_stay_in_range_repeat_per_seed_and_do_not_disturb_other_axes():
    task = load_task(TASK)
    context = Context(task, load_catalog(), ("external_left", "wrist"), 7)
    everything = Variations.create(ALL_AXES)
    draws = [everything.draw(seed, context).fields for seed in range(40)]
    for fields in draws:
        assert 0.05 <= fields["light_intensity"] <= 3.0 and fields["light_environment"] in ENVIRONMENT_LEVELS
        assert fields["light_color"] in LIGHT_COLORS and fields["light_direction"] in LIGHT_DIRECTIONS
        assert 0.0 <= fields["light_ambient"] <= 0.08
        for name in ("external_left", "wrist"):
            xy, z, rot = (0.2, 0.1, 0.2) if name != "wrist" else (0.015, 0.0, 0.05)
            assert abs(fields[f"cam_{name}_dx"]) <= xy and abs(fields[f"cam_{name}_dy"]) <= xy
            assert abs(fields[f"cam_{name}_dz"]) <= z
            assert all(abs(fields[f"cam_{name}_{k}"]) <= rot for k in ("droll", "dpitch", "dyaw"))
        assert "cam_external_right_dx" not in fields  # not a camera of this environment
        assert all(abs(fields[f"robot_joint{i}_offset"]) <= 0.1 for i in range(1, 8))
        assert 0.0 <= fields["image_noise_std"] <= 8.0
        assert fields["distractor_banana_color"] == "own"  # the Rubik's cube takes every colour the banana could
    assert everything.draw(3, context).fields == draws[3]
    assert len({json.dumps(fields, sort_keys=True) for fields in draws}) == len(draws)
    assert len({fields["background"] for fields in draws}) > 5
    assert len({fields["table_material"] for fields in draws}) > 5
    lighting_only = Variations.create("lighting").draw(3, context).fields
    assert lighting_only == {key: value for key, value in draws[3].items() if key.startswith("light_")}
    green = load_task("PickUpGreenObject")
    swaps = Variations.create("distractors").draw(0, Context(green, load_catalog(), (), 7)).fields
    taken = task_colours(Context(green, load_catalog(), (), 7))
    assert {"green", "dark_green", "light_green"} <= taken
    colours = [value for key, value in swaps.items() if key.endswith("_color")]
    assert len(colours) == 3 and not set(colours) & taken and set(colours) <= set(COLOR_NAMES)


def test_suites_are_listed_with_their_conditions():
    known = suites()
    assert list(known) == ["lighting", "background", "table", "camera", "objects"]
    assert {"dim", "bright", "directional", "red", "green", "blue"} <= set(known["lighting"].conditions)
    assert list(known["camera"].conditions) == ["default", "external", "wrist", "both"]
    assert list(known["objects"].conditions) == ["default", "10cm", "20cm", "30cm"]
    assert {"bamboo", "black_matte", "light_wood", "wood_planks"} <= set(known["table"].conditions)
    for suite in known.values():
        assert suite.conditions["default"] == ""
        for settings in suite.conditions.values():
            Variations.create(settings)  # every condition parses
    assert suite_conditions("objects:20cm/default")[1] == {"default": "", "20cm": "objects=20cm"}
    with pytest.raises(VariationError, match="unknown condition 'huge'"):
        suite_conditions("objects:huge")
    listing = subprocess.run([ROBOLAB, "suites"], capture_output=True, text=True, timeout=120)
    assert listing.returncode == 0, listing.stderr
    assert "lighting: RoboLab's lighting conditions" in listing.stdout and "wrist     camera=wrist" in listing.stdout
    for axis in AXES:
        assert f"  {axis}: " in listing.stdout


# ------------------------------------------------------------------------------------------------ each axis
def test_no_variations_leaves_the_environment_as_it_was(env):
    observe(env, ALL_AXES, seed=4)  # an episode with every axis first: nothing of it may stay behind
    reused = observe(env, None, seed=2)
    fresh_env = make()
    fresh = observe(fresh_env, None, seed=2)
    fresh_env.close()
    assert reused["fields"] == {} == fresh["fields"]
    for name in fresh["images"]:
        assert np.array_equal(reused["images"][name], fresh["images"][name])
    assert all(torch.equal(reused["positions"][n], fresh["positions"][n]) for n in fresh["positions"])


def test_lighting_changes_brightness_colour_and_shadows(env):
    plain = observe(env, None)["images"]["external_left"]
    dim = observe(env, "lighting=dim")
    bright = observe(env, "lighting=bright")["images"]["external_left"]
    red = observe(env, "lighting=red")["images"]["external_left"]
    top = observe(env, "lighting=top")["images"]["external_left"]
    assert dim["fields"]["light_intensity"] == 0.01 and dim["fields"]["light_environment"] == 0.1
    assert brightness(dim["images"]["external_left"]) < 0.7 * brightness(plain) < 0.7 * brightness(bright)
    share = lambda image: image[..., 0].astype(float).mean() / image.astype(float).mean()  # noqa: E731
    assert share(red) > 1.1 * share(plain)
    assert np.abs(top.astype(int) - plain.astype(int)).mean() > 1.0  # shadows fall elsewhere


def test_background_and_table_change_the_images(env):
    night = observe(env, "background=night")
    sky = observe(env, "background=sky")
    assert night["fields"] == {"background": "night"}
    assert np.abs(night["images"]["external_left"].astype(int) - sky["images"]["external_left"].astype(int)).mean() > 3
    plain = observe(env, None)["images"]
    black = observe(env, "table=black_matte")
    assert black["fields"] == {"table_material": "black_matte"}
    assert brightness(black["images"]["wrist"]) < 0.7 * brightness(plain["wrist"])  # the wrist camera sees the table


def test_camera_offsets_move_their_own_camera_by_the_drawn_amount(env):
    plain = observe(env, None, seed=5)
    external = observe(env, "camera=external", seed=5)
    wrist = observe(env, "camera=wrist", seed=5)
    assert np.array_equal(external["images"]["wrist"], plain["images"]["wrist"])
    assert not np.array_equal(external["images"]["external_left"], plain["images"]["external_left"])
    assert np.array_equal(wrist["images"]["external_left"], plain["images"]["external_left"])
    assert not np.array_equal(wrist["images"]["wrist"], plain["images"]["wrist"])
    assert wrist["fields"]["cam_wrist_dz"] == 0.0 and abs(wrist["fields"]["cam_wrist_dx"]) <= 0.015
    observe(env, "camera=external", seed=5)
    moved = env.unwrapped._sensors["external_left"].camera.global_pose.p[0].numpy()
    nominal = cameras.external_pose("left").p
    offsets = [external["fields"][f"cam_external_left_{k}"] for k in ("dx", "dy", "dz")]
    assert np.allclose(moved - nominal, offsets, atol=1e-5)


def test_object_poses_move_within_range_apart_on_the_table_and_unsolved(env):
    from robolab_ms.scene import TABLE_CENTER_XY
    from robolab_ms.variations.objects import MARGIN, _bodies, _geometric_conditions, _solved

    base = env.unwrapped
    plain = observe(env, None, seed=0)["positions"]
    moved_any = False
    names = ("bowl", "rubiks_cube", "banana")
    for seed in range(4):
        result = observe(env, "objects=0.3", seed=seed)
        fields = result["fields"]
        assert set(fields) == {f"obj_{n}_{k}" for n in names for k in ("dx", "dy", "dyaw")}
        assert all(abs(fields[f"obj_{n}_{k}"]) <= 0.3 + 1e-6 for n in names for k in ("dx", "dy"))
        for placement in base.task_spec.scene.objects:  # the fields are the true offsets from the layout
            position = result["positions"][placement.name]
            assert abs(float(position[0]) - placement.xy[0] - fields[f"obj_{placement.name}_dx"]) < 1e-4
        moved_any |= any(float((result["positions"][n] - plain[n]).norm()) > 0.05 for n in plain)
        bodies = list(_bodies(base).values())
        half = np.asarray(base.task_spec.scene.table_size) / 2
        low, high = np.asarray(TABLE_CENTER_XY) - half, np.asarray(TABLE_CENTER_XY) + half
        for i, a in enumerate(bodies):
            outline = a.outline()
            assert (outline >= low).all() and (outline <= high).all()
            for b in bodies[:i]:
                assert gap(outline, b.outline()) >= MARGIN - 1e-6, (seed, a.name, b.name)
        assert not result["success"]
        geometric = _geometric_conditions(base) or list(base.task_spec.success)
        assert not _solved(base, geometric)  # not even the cube behind the bowl, before any contact
        start = {n: a.pose.p[0].clone() for n, a in base.objects.items()}
        hold = np.concatenate([base.arm_qpos()[0].numpy(), [0.0]]).astype(np.float32)
        for _ in range(10):  # nothing starts in collision: nothing is pushed
            env.step(hold)
        assert all(float((a.pose.p[0] - start[n]).norm()) < 0.01 for n, a in base.objects.items())
    assert moved_any


def test_robot_joints_start_at_the_drawn_offsets(env):
    home = observe(env, None, seed=1)["arm"]
    varied = observe(env, "robot=0.2", seed=1)
    offsets = torch.tensor([varied["fields"][f"robot_joint{i}_offset"] for i in range(1, 8)])
    assert (offsets.abs() <= 0.2).all() and (offsets.abs() > 0).any()
    assert torch.allclose(varied["arm"] - home, offsets, atol=1e-4)


def test_image_noise_has_the_drawn_strength(env):
    plain = observe(env, None, seed=2)["images"]
    noisy = observe(env, "noise=6", seed=2)
    assert noisy["fields"] == {"image_noise_std": 6.0}
    for name in plain:
        difference = noisy["images"][name].astype(float) - plain[name].astype(float)
        assert 4.5 < difference.std() < 7.0 and abs(difference.mean()) < 1.0


def test_distractor_swaps_restyle_only_distractors(env):
    import sapien

    def textures(name):
        entity = env.unwrapped.objects[name]._objs[0]
        component = entity.find_component_by_type(sapien.render.RenderBodyComponent)
        return [part.material.base_color_texture for shape in component.render_shapes for part in shape.parts]

    observe(env, None, seed=0)
    banana, bowl = textures("banana"), textures("bowl")
    swapped = observe(env, "distractors.texture=metal", seed=0)
    assert swapped["fields"] == {"distractor_banana_color": "own", "distractor_banana_texture": "metal"}
    assert all(t is not None and t.download().mean() > 0 for t in textures("banana"))
    assert [t.download().tobytes() for t in textures("banana")] != [t.download().tobytes() for t in banana]
    assert [t.download().tobytes() for t in textures("bowl")] == [t.download().tobytes() for t in bowl]


def test_restyle_recolours_procedural_and_tints_image_textured_objects():
    import sapien

    from robolab_ms.variations.distractors import restyle

    catalog = load_catalog()
    scene = sapien.Scene()
    butter = catalog["butter_box"]
    assert butter.source.get("textured")
    actor = butter.build(scene, "butter_box", sapien.Pose())

    class Wrapped:  # what restyle reads of a ManiSkill actor
        _objs = [actor]

    restyle(Wrapped, butter, "blue", "own")  # an image texture is kept and tinted
    materials = [
        p.material
        for s in actor.find_component_by_type(sapien.render.RenderBodyComponent).render_shapes
        for p in s.parts
    ]
    assert all(np.allclose(m.base_color[:3], COLOR_NAMES["blue"]) for m in materials)
    restyle(Wrapped, butter, "red", "plastic")  # a generated texture replaces it
    assert all(m.base_color_texture.filename == "" or m.base_color_texture.filename is None for m in materials)
    texel = materials[0].base_color_texture.download()[..., :3].reshape(-1, 3).mean(axis=0)
    assert texel[0] > 2 * texel[1]


# ------------------------------------------------------------------------------------------------ determinism
def test_same_seed_same_parameters_and_images_fresh_or_reused(env):
    for seed in (11, 3):  # other episodes run first in the reused environment
        observe(env, ALL_AXES, seed=seed)
    reused = observe(env, ALL_AXES, seed=7)
    fresh_env = make(variations=ALL_AXES)
    _, _ = fresh_env.reset(seed=99)
    fresh = observe(fresh_env, ALL_AXES, seed=7)
    fresh_env.close()
    assert reused["fields"] == fresh["fields"]
    assert {
        "background",
        "table_material",
        "light_intensity",
        "obj_bowl_dx",
        "robot_joint1_offset",
        "cam_wrist_dyaw",
        "image_noise_std",
        "distractor_banana_texture",
    } <= set(fresh["fields"])
    for name in fresh["images"]:
        assert np.array_equal(reused["images"][name], fresh["images"][name]), name
    assert all(torch.equal(reused["positions"][n], fresh["positions"][n]) for n in fresh["positions"])
    other = observe(env, ALL_AXES, seed=8)
    assert other["fields"] != fresh["fields"]


def test_variations_need_one_environment():
    with pytest.raises(Exception, match="num_envs=1"):
        gym.make(f"RoboLab-{TASK}-v1", obs_mode="state_dict", num_envs=2, variations="lighting")


# ------------------------------------------------------------------------------------------------ eval, suites, results
@pytest.mark.slow
def test_suite_runs_one_folder_per_condition_and_lines_carry_the_parameters(tmp_path):
    out = tmp_path / "suite"
    args = [
        ROBOLAB,
        "eval",
        "--policy",
        "random",
        "--task",
        TASK,
        "--episodes",
        "2",
        "--max-steps",
        "2",
        "--quiet",
        "--suite",
        "objects:default/20cm",
        "--vary",
        "robot=0.05",
        "--out",
        str(out),
    ]
    run = subprocess.run(args, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr
    plain, moved = read_results(out / "default"), read_results(out / "20cm")
    assert len(plain) == len(moved) == 2
    assert {r.condition for r in plain} == {"default"} and {r.variations for r in plain} == {"robot=0.05"}
    assert {r.variations for r in moved} == {"robot=0.05,objects=20cm"}
    line = json.loads((out / "20cm" / "episodes.jsonl").read_text().splitlines()[0])
    fields = line["variation"]
    assert isinstance(fields["obj_bowl_dx"], float) and abs(fields["obj_bowl_dx"]) <= 0.2
    assert isinstance(fields["robot_joint3_offset"], float) and "obj_bowl_dx" not in plain[0].variation
    manifest = json.loads((out / "20cm" / "manifest.json").read_text())
    assert manifest["variations"]["ranges"]["objects"]["xy"] == [-0.2, 0.2]
    assert manifest["rerun"].endswith("--vary robot=0.05,objects=20cm")
    table = (out / "suite.md").read_text()
    assert "| task | default | 20cm |" in table and "all tasks" in table and TASK in table
    assert "obj_bowl_dx" in (out / "20cm" / "tasks" / f"{TASK}.csv").read_text().splitlines()[0]
    again = [
        ROBOLAB,
        "eval",
        "--policy",
        "random",
        "--task",
        TASK,
        "--episodes",
        "1",
        "--max-steps",
        "2",
        "--quiet",
        "--out",
        str(out / "20cm"),
    ]
    mixed = subprocess.run(again, capture_output=True, text=True, timeout=600)
    assert mixed.returncode == 2 and "give another --out" in mixed.stderr
    bad = subprocess.run(
        [ROBOLAB, "eval", "--task", TASK, "--vary", "lightning", "--out", str(tmp_path / "x")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert bad.returncode == 2 and "unknown axis 'lightning'" in bad.stderr


def test_old_result_lines_read_without_variation_fields(tmp_path):
    old = {
        "task": "BananaInBowl",
        "instruction_variant": "default",
        "instruction": "x",
        "robot": "droid",
        "policy": "random",
        "seed": 0,
        "success": False,
        "score": 0.0,
        "progress": 0.0,
        "steps": 1,
        "max_steps": 1,
        "success_step": None,
        "wall_seconds": 0.1,
        "version": 1,
    }
    (tmp_path / "episodes.jsonl").write_text(json.dumps(old) + "\n")
    (result,) = read_results(tmp_path)
    assert isinstance(result, EpisodeResult)
    assert result.variations is None and result.condition is None and result.variation == {}
    assert math.isclose(result.wall_seconds, 0.1)
