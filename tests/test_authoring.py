"""Authoring outside the package: task files by path, user content folders, the episode length of the loaded file,
scene footprints under jitter, and an installation made by `make` reading the checkout's content."""

import json
import os
import re
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from robolab_ms.content import CHECKOUT_ENV, CHECKOUT_FILE, CONTENT_ENV, content_dir
from robolab_ms.errors import RoboLabError, SpecError
from robolab_ms.scene import read_scene
from robolab_ms.tasks.spec import load_task, task_names

REPO = Path(__file__).resolve().parents[1]
ROBOLAB = [sys.executable, "-m", "robolab_ms.cli"]

SCENE = """
name: {name}
description: A banana and a bowl.
table: {{size: [0.9, 1.2], color: {color}}}
objects:
  - {{name: banana, asset: banana, xy: [0.48, 0.16], yaw_deg: 20}}
  - {{name: bowl, asset: bowl_white, xy: [0.55, -0.14]}}
"""

TASK = """
name: {name}
scene: {scene}
episode_seconds: {seconds}
attributes: [{attribute}]
instructions: {{default: Put the banana in the bowl., vague: Tidy up., specific: Put the yellow banana in the bowl.}}
success:
  - {{predicate: in_container, objects: [banana], container: bowl, require_gripper_detached: true}}
"""


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def task(folder: Path, name: str, scene: str = "banana_bowl", seconds: float = 20, attribute: str = "color") -> Path:
    return write(folder / f"{name}.yaml", TASK.format(name=name, scene=scene, seconds=seconds, attribute=attribute))


def scene(folder: Path, name: str, color: str = "white") -> Path:
    return write(folder / f"{name}.yaml", SCENE.format(name=name, color=color))


def content_root(root: Path, task_name: str = "MyBananaTask", scene_name: str = "my_banana_scene") -> Path:
    """A user content folder: task_specs/<task_name>.yaml on scene_builders/<scene_name>.yaml."""
    scene(root / "scene_builders", scene_name)
    task(root / "task_specs", task_name, scene=scene_name, seconds=4)
    return root


def robolab(*args: str, env: dict | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    environment = {**os.environ, "PYTHONPATH": str(REPO), **(env or {})}
    return subprocess.run([*ROBOLAB, *args], capture_output=True, text=True, env=environment, cwd=cwd, timeout=600)


# ------------------------------------------------------------------------------------------------ finding content
def test_a_task_file_finds_its_scene_next_to_it_in_a_sibling_folder_or_by_name(tmp_path):
    scene(tmp_path / "loose", "my_scene", color="white")
    loose = load_task(task(tmp_path / "loose", "LooseTask", scene="my_scene"))
    assert loose.scene.file == tmp_path / "loose" / "my_scene.yaml" and loose.name == "LooseTask"

    scene(tmp_path / "root" / "scene_builders", "my_scene", color="grey")  # same name, another folder: its own wins
    rooted = load_task(task(tmp_path / "root" / "task_specs", "RootedTask", scene="my_scene"))
    assert rooted.scene.file == tmp_path / "root" / "scene_builders" / "my_scene.yaml"

    shipped = load_task(str(task(tmp_path / "other", "ShippedSceneTask", scene="banana_bowl")))
    assert shipped.scene.file == content_dir("scenes") / "banana_bowl.yaml"

    with pytest.raises(SpecError, match=r"OtherTask.yaml: field 'scene'.*unknown scene 'my_scen'.*my_scene"):
        load_task(task(tmp_path / "loose", "OtherTask", scene="my_scen"))
    with pytest.raises(RoboLabError, match="task file 'nowhere/T.yaml' does not exist"):
        load_task("nowhere/T.yaml")


def test_edits_count_at_once_in_a_running_process(tmp_path):
    path = task(tmp_path, "EditedTask", seconds=20)
    assert load_task(path).max_episode_steps == 300
    task(tmp_path, "EditedTask", seconds=3)
    assert load_task(path).max_episode_steps == 45


def test_content_folders_from_the_variable_and_name_clashes(tmp_path, monkeypatch):
    root = content_root(tmp_path / "mine")
    assert "MyBananaTask" not in task_names()
    monkeypatch.setenv(CONTENT_ENV, os.pathsep.join([str(root), str(root)]))  # a folder given twice counts once
    assert "MyBananaTask" in task_names()
    spec = load_task("RoboLab-MyBananaTask-v1")
    assert spec.scene.file == root / "scene_builders" / "my_banana_scene.yaml" and spec.max_episode_steps == 60

    clash = tmp_path / "clash"
    task(clash / "task_specs", "BananaInBowl")
    monkeypatch.setenv(CONTENT_ENV, str(clash))
    with pytest.raises(
        RoboLabError,
        match=r"task 'BananaInBowl' is defined twice: .*task_specs/BananaInBowl.yaml and "
        r".*clash/task_specs/BananaInBowl.yaml.*rename one",
    ):
        task_names()
    monkeypatch.setenv(CONTENT_ENV, str(tmp_path / "missing"))
    with pytest.raises(RoboLabError, match="ROBOLAB_CONTENT: '.*missing' is not a folder"):
        task_names()


# ------------------------------------------------------------------------------------------------ the CLI
@pytest.mark.slow
def test_cli_takes_task_files_and_content_folders(tmp_path):
    root = content_root(tmp_path / "mine")
    listing = robolab("list", "--content", str(root))
    assert listing.returncode == 0, listing.stderr
    row = next(line for line in listing.stdout.splitlines() if line.startswith("MyBananaTask"))
    assert "RoboLab-MyBananaTask-v1" in row and "my_banana_scene" in row and row.split()[-1] == "4"
    assert "BananaInBowl" in listing.stdout and str(root / "task_specs") in listing.stdout
    assert "MyBananaTask" not in robolab("list").stdout

    loose = task(tmp_path / "loose", "LooseTask", seconds=7, attribute="size")
    listing = robolab("list", "--task", str(loose), "BananaInBowl")
    assert listing.returncode == 0, listing.stderr
    assert [line.split()[0] for line in listing.stdout.splitlines()[1:3]] == ["LooseTask", "BananaInBowl"]

    clash = tmp_path / "clash"
    task(clash / "task_specs", "BananaInBowl")
    failed = robolab("list", "--content", str(clash))
    assert failed.returncode == 2 and "defined twice" in failed.stderr and "Traceback" not in failed.stderr

    out = tmp_path / "run"
    evaluated = robolab(
        "eval",
        "--policy",
        "random",
        "--task",
        str(loose),
        "RoboLab-MyBananaTask-v1",
        "--content",
        str(root),
        "--episodes",
        "1",
        "--max-steps",
        "3",
        "--out",
        str(out),
        "--quiet",
    )
    assert evaluated.returncode == 0, evaluated.stderr
    episodes = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert [(e["task"], e["steps"], e["error"]) for e in episodes] == [
        ("LooseTask", 3, None),
        ("MyBananaTask", 3, None),
    ]
    assert episodes[0]["max_steps"] == 3 and episodes[0]["instruction"] == "Put the banana in the bowl."

    missing = robolab("validate", "--task", str(tmp_path / "Nope.yaml"), "--out", str(out))
    assert missing.returncode == 2 and "does not exist" in missing.stderr and "Traceback" not in missing.stderr


def test_content_variable_registers_env_ids_through_the_startup_hook(tmp_path):
    root = content_root(tmp_path / "mine")
    code = (
        "import mani_skill.envs, gymnasium as gym; env = gym.make('RoboLab-MyBananaTask-v1', render_backend='cpu');"
        "print(env.unwrapped.task_spec.file, env.get_wrapper_attr('_max_episode_steps')); env.close()"
    )
    result = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "PYTHONPATH": str(REPO), CONTENT_ENV: str(root)},
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.split() == [str(root / "task_specs" / "MyBananaTask.yaml"), "60"]


# ------------------------------------------------------------------------------------------------ gym.make
def test_gym_make_with_a_task_file_takes_everything_from_the_file(tmp_path):
    import robolab_ms.envs  # noqa: F401  (registers the shipped tasks)

    path = task(tmp_path, "ShortBanana", seconds=2, attribute="size")  # 30 steps; BananaInBowl has 750
    env = gym.make("RoboLab-BananaInBowl-v1", task=str(path), obs_mode="state_dict", render_backend="cpu")
    try:
        base = env.unwrapped
        assert base.task_spec.name == "ShortBanana" and base.task_spec.attributes == ("size",)
        assert base.instruction == "Put the banana in the bowl."
        assert env.get_wrapper_attr("_max_episode_steps") == 30
        env.reset(seed=0)
        hold = np.concatenate([base.arm_qpos()[0].numpy(), [0.0]]).astype(np.float32)
        truncated = [bool(env.step(hold)[3][0]) for _ in range(30)]
        assert truncated == [False] * 29 + [True]
        _, info = env.reset(seed=0)
        assert info["task"] == "ShortBanana"
    finally:
        env.close()
    env = gym.make(
        "RoboLab-BananaInBowl-v1", task=str(path), max_episode_steps=5, obs_mode="state_dict", render_backend="cpu"
    )
    try:
        assert env.get_wrapper_attr("_max_episode_steps") == 5  # an explicit length still wins
    finally:
        env.close()


# ------------------------------------------------------------------------------------------------ scene footprints
def test_an_object_that_the_jitter_pushes_over_the_table_edge_is_refused(tmp_path):
    text = SCENE.format(name="edge", color="white").replace("[0.9, 1.2]", "[0.9, 0.8]")
    # the bowl (21 cm across) at y -0.28 ends 1 cm inside the 0.8 m wide table (y -0.4), 1 cm short of the jitter
    ok = write(tmp_path / "edge.yaml", text.replace("[0.55, -0.14]", "[0.55, -0.28]") + "jitter: {xy: 0.005}\n")
    assert read_scene(ok).table_size == (0.9, 0.8)
    bad = write(tmp_path / "edge.yaml", text.replace("[0.55, -0.14]", "[0.55, -0.28]") + "jitter: {xy: 0.02}\n")
    with pytest.raises(
        SpecError,
        match=r"edge.yaml: field 'objects\[1\].xy': 'bowl' reaches 0\.\d cm past the table's "
        r"edge at y = -0.400 m at some poses the jitter allows.*Move it at least",
    ):
        read_scene(bad)


def test_catalog_list_shows_graspable_width_and_colours():
    result = robolab("catalog", "list")
    assert result.returncode == 0, result.stderr
    header, *rows = result.stdout.splitlines()
    assert header.split()[:3] == ["object", "class", "shape"] and "grasp (cm)" in header and "colours" in header
    by_name = {row.split()[0]: row for row in rows if row.strip()}
    banana, bowl = by_name["banana"].split(), by_name["bowl_white"].split()
    assert "yes" in banana and "yellow" in banana and "no" in bowl and "white" in bowl
    assert banana[2] == "primitive" and by_name["ketchup"].split()[2] == "scanned"  # HOPE's scanned bottle
    assert re.search(r"\d+ scanned, \d+ modelled, \d+ primitive", result.stdout)
    assert "85 mm opening" in result.stdout


# ------------------------------------------------------------------------------------------------ a make install
@pytest.mark.slow
def test_an_install_made_by_make_reads_the_checkouts_content(tmp_path):
    """`make` installs with ROBOLAB_MS_LINK_CHECKOUT=1: a task added to the checkout afterwards is known at once to
    the installed `robolab` and to the start-up hook; a build without it ships no link."""
    import site

    checkout = tmp_path / "checkout"
    checkout.mkdir()
    for name in ("setup.py", "pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, checkout / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for folder in ("robolab_ms", "eval", "analysis", "assets", "scene_builders", "task_specs"):
        shutil.copytree(REPO / folder, checkout / folder, symlinks=True, ignore=ignore)
    fresh = tmp_path / "venv"
    venv.create(fresh, with_pip=False)
    python = fresh / "bin" / "python"
    purelib = Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    )
    (purelib / "deps.pth").write_text(site.getsitepackages()[0] + "\n")
    environment = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH", CONTENT_ENV)}
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "--python",
            str(python),
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            str(checkout),
        ],
        check=True,
        timeout=600,
        cwd=tmp_path,
        env={**environment, CHECKOUT_ENV: "1"},
    )
    assert (purelib / "robolab_ms" / CHECKOUT_FILE).read_text().strip() == str(checkout)

    task(checkout / "task_specs", "AddedAfterInstall", seconds=9)
    listing = subprocess.run(
        [str(fresh / "bin" / "robolab"), "list"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=environment,
        timeout=600,
    )
    assert listing.returncode == 0, listing.stderr
    assert "AddedAfterInstall" in listing.stdout and str(checkout / "task_specs") in listing.stdout
    code = "import mani_skill.envs, gymnasium as gym; print('RoboLab-AddedAfterInstall-v1' in gym.registry)"
    hooked = subprocess.run(
        [str(python), "-c", code], capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=600
    )
    assert hooked.stdout.strip() == "True", hooked.stderr[-2000:]

    wheels = tmp_path / "wheels"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--wheel-dir",
            str(wheels),
            str(checkout),
        ],
        check=True,
        timeout=600,
        cwd=tmp_path,
        env=environment,
    )
    import zipfile

    (wheel,) = wheels.glob("robolab_ms-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert f"robolab_ms/{CHECKOUT_FILE}" not in names and "robolab_ms/task_specs/BananaInBowl.yaml" in names
