"""Content files: the shipped ones load; mistakes give one clear error naming the file, the field and a fix."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from robolab_ms.catalog import load_catalog, read_catalog
from robolab_ms.errors import SpecError, UnknownNameError
from robolab_ms.scene import read_scene
from robolab_ms.tasks.spec import load_all_tasks, load_task, read_task

SCENE = """
name: {name}
objects:
  - {{name: banana, asset: {asset}, xy: [0.5, 0.1]}}
"""

TASK = """
name: {name}
scene: banana_bowl
episode_seconds: 50
attributes: [semantics]
instructions: {{default: a, vague: b, specific: c}}
success:
  - {{predicate: {predicate}, objects: [{obj}], container: bowl}}
"""


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return path


def test_shipped_content_loads():
    assert len(load_catalog()) >= 6
    tasks = load_all_tasks()
    assert "BananaInBowl" in [t.name for t in tasks]
    spec = load_task("RoboLab-BananaInBowl-v1")
    assert spec.max_episode_steps == 750
    assert (spec.num_subtasks, spec.difficulty_score, spec.difficulty) == (1, 1, "simple")
    assert set(spec.instructions) == {"default", "vague", "specific"}


def test_scene_with_unknown_object_names_file_field_and_suggestion(tmp_path):
    path = write(tmp_path, "s", SCENE.format(name="s", asset="bananna"))
    with pytest.raises(SpecError) as error:
        read_scene(path)
    message = str(error.value)
    assert str(path) in message and "objects[0].asset" in message and "Did you mean 'banana'?" in message


def test_scene_with_misspelt_field(tmp_path):
    path = write(tmp_path, "s", SCENE.format(name="s", asset="banana").replace("objects:", "objetcs:"))
    with pytest.raises(SpecError, match=r"'objetcs': is not a known field. Did you mean 'objects'\?"):
        read_scene(path)


def test_task_with_unknown_predicate(tmp_path):
    path = write(tmp_path, "T", TASK.format(name="T", predicate="in_containr", obj="banana"))
    with pytest.raises(SpecError, match=r"success\[0\].predicate.*Did you mean 'in_container'"):
        read_task(path)


def test_task_with_object_missing_from_scene(tmp_path):
    path = write(tmp_path, "T", TASK.format(name="T", predicate="in_container", obj="bananas"))
    with pytest.raises(SpecError, match=r"success\[0\].objects\[0\].*'bananas'.*Did you mean 'banana'\?"):
        read_task(path)


def test_broken_yaml_names_the_line(tmp_path):
    path = write(tmp_path, "T", "name: T\nscene: [banana_bowl\n")
    with pytest.raises(SpecError, match=r"line \d+.*not valid YAML"):
        read_task(path)


def test_catalog_with_bad_mass(tmp_path):
    path = write(tmp_path, "c", "objects:\n  x: {class: fruit, description: d, colors: [red], mass: -1, "
                 "friction: {static: 1, dynamic: 1}, license: CC0, "
                 "source: {kind: procedural, generator: box, params: {size: [0.1, 0.1, 0.1]}}}\n")  # fmt: skip
    with pytest.raises(SpecError, match=r"objects.x.*mass.*must be positive"):
        read_catalog(path)


def test_unknown_task_suggests():
    with pytest.raises(UnknownNameError, match="Did you mean 'BananaInBowl'"):
        load_task("BananaInBowel")


def test_no_rendering_device_is_explained(tmp_path):
    robolab = str(Path(sys.executable).with_name("robolab"))
    broken = {**os.environ, "VK_ICD_FILENAMES": "/nonexistent.json", "VK_DRIVER_FILES": "/nonexistent.json"}
    result = subprocess.run([robolab, "eval", "--task", "BananaInBowl", "--episodes", "1", "--out", str(tmp_path)],
                            capture_output=True, text=True, env=broken, timeout=300)  # fmt: skip
    assert result.returncode == 2, result.stderr[-2000:]
    assert "mesa-vulkan-drivers" in result.stderr and "Traceback" not in result.stderr


STAGED = """
name: T
scene: banana_bowl
episode_seconds: 30
attributes: [conjunction, stacking]
instructions: {default: a, vague: b, specific: c}
success:
  - {predicate: in_container, objects: [banana, apple], container: bowl}
subtasks:
  - objects: [banana]
    steps:
      - {predicate: grasped, weight: 0}
      - {predicate: in_container, container: bowl, require_gripper_detached: true, weight: 1}
  - objects: [apple, red_block]
    logical: choose
    k: 1
    steps:
      - {predicate: in_container, container: bowl}
events: {tip_angle: 0.5}
"""


def test_subtask_stages_difficulty_and_event_thresholds(tmp_path):
    spec = read_task(write(tmp_path, "T", STAGED))
    assert [len(stage.steps) for stage in spec.subtasks] == [2, 1]
    assert spec.num_subtasks == 2  # 1 object in stage 1, choose 1 in stage 2
    assert spec.difficulty_score == 4 and spec.difficulty == "moderate"  # + stacking weight 2
    assert spec.event_thresholds["tip_angle"] == 0.5
    conditions, stages, targets = spec.progress_layout()
    assert [c.predicate for c in conditions] == ["grasped", "in_container", "in_container"]
    assert [g.conditions for g in stages[0].groups] == [(0, 1)]
    assert [g.conditions for g in stages[1].groups] == [(2,), (3,)]
    assert targets == [("banana",), ("apple", "red_block")]


def test_subtask_step_with_unknown_field(tmp_path):
    path = write(tmp_path, "T", STAGED.replace("weight: 0}", "wieght: 0}"))
    with pytest.raises(SpecError, match=r"subtasks\[0\].steps\[0\].wieght.*Did you mean 'weight'"):
        read_task(path)


def test_unknown_event_threshold(tmp_path):
    path = write(tmp_path, "T", STAGED.replace("tip_angle", "tilt_angle"))
    with pytest.raises(SpecError, match=r"events.tilt_angle.*Did you mean 'tip_angle'"):
        read_task(path)


def test_every_registered_task_is_not_a_success_right_after_reset():
    import gymnasium as gym

    from robolab_ms.envs import ENV_IDS

    for env_id in ENV_IDS:
        env = gym.make(env_id, obs_mode="state_dict", render_backend="cpu")
        for seed in (0, 1):
            _, info = env.reset(seed=seed)
            assert not info["success"].item(), f"{env_id} seed {seed}"
            _, _, _, _, info = env.step(None)
            assert not info["success"].item(), f"{env_id} seed {seed} after one step"
        env.close()


def test_the_task_writing_page_documents_every_predicate_and_event():
    from robolab_ms.tasks.events import EVENT_THRESHOLDS, EVENT_TYPES
    from robolab_ms.tasks.predicates import PREDICATES

    page = (Path(__file__).parent.parent / "docs" / "writing_tasks.md").read_text()
    for name in [*PREDICATES, *EVENT_TYPES, *EVENT_THRESHOLDS]:
        assert f"`{name}`" in page, name
