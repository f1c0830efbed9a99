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
    assert str(path) in message and "objects[0].asset" in message and "Did you mean 'banana'" in message


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
    path = write(
        tmp_path,
        "c",
        "objects:\n  x: {class: fruit, description: d, colors: [red], mass: -1, "
        "friction: {static: 1, dynamic: 1}, license: CC0, "
        "source: {kind: procedural, generator: box, params: {size: [0.1, 0.1, 0.1]}}}\n",
    )
    with pytest.raises(SpecError, match=r"objects.x.*mass.*must be positive"):
        read_catalog(path)


def test_unknown_task_suggests():
    with pytest.raises(UnknownNameError, match="Did you mean 'BananaInBowl'"):
        load_task("BananaInBowel")


def test_no_rendering_device_is_explained(tmp_path):
    robolab = str(Path(sys.executable).with_name("robolab"))
    broken = {**os.environ, "VK_ICD_FILENAMES": "/nonexistent.json", "VK_DRIVER_FILES": "/nonexistent.json"}
    result = subprocess.run(
        [robolab, "eval", "--task", "BananaInBowl", "--episodes", "1", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        env=broken,
        timeout=300,
    )
    assert result.returncode == 2, result.stderr[-2000:]
    assert "mesa-vulkan-drivers" in result.stderr and "Traceback" not in result.stderr


STAGED_SCENE = """name: staged
jitter: {xy: 0, yaw_deg: 0}
objects:
  - {name: banana, asset: banana, xy: [0.45, 0.2]}
  - {name: bowl, asset: bowl_white, xy: [0.55, -0.15]}
  - {name: apple, asset: apple_red, xy: [0.7, 0.1]}
  - {name: red_block, asset: block_red, xy: [0.4, -0.02]}
"""

STAGED = """
name: T
scene: staged.yaml
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
    write(tmp_path, "staged", STAGED_SCENE)
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
    write(tmp_path, "staged", STAGED_SCENE)
    path = write(tmp_path, "T", STAGED.replace("weight: 0}", "wieght: 0}"))
    with pytest.raises(SpecError, match=r"subtasks\[0\].steps\[0\].wieght.*Did you mean 'weight'"):
        read_task(path)


def test_unknown_event_threshold(tmp_path):
    write(tmp_path, "staged", STAGED_SCENE)
    path = write(tmp_path, "T", STAGED.replace("tip_angle", "tilt_angle"))
    with pytest.raises(SpecError, match=r"events.tilt_angle.*Did you mean 'tip_angle'"):
        read_task(path)


@pytest.mark.slow
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


BASE_TASK = """name: T
scene: staged.yaml
episode_seconds: 50
instructions: {default: a, vague: b, specific: c}
success:
  - {predicate: in_container, objects: [banana], container: bowl}
"""


@pytest.mark.parametrize(
    "old, new, field, hint",
    [
        ("episode_seconds: 50", "episode_seconds: .nan", "episode_seconds", "finite number"),
        ("episode_seconds: 50", "episode_seconds: 0.05", "episode_seconds", "shorter than one control step"),
        ("episode_seconds: 50", "episode_seconds: 1.0e+9", "episode_seconds", "more than an hour"),
        ("episode_seconds: 50", "episode_seconds: 1e9", "episode_seconds", "write 1.0e+9"),
        ("vague: b", "vague: ' '", "instructions.vague", "is empty"),
        ("[banana]", "[banana, banana]", "success[0].objects[1]", "listed twice"),
        ("container: bowl", "container: banana", "success[0].container", "also an object of this condition"),
        ("container: bowl", "container: table", "success[0].container", "not a container"),
        ("[banana]", "[table]", "success[0].objects[0]", "table cannot be moved"),
        ("bowl}", "bowl, tolerance: -0.1}", "success[0].tolerance", "between 0 and 0.5"),
        ("bowl}", "bowl, k: 1}", "success[0].k", "only with logical: choose"),
        ("bowl}", "bowl}\nevents: {tip_angle: .inf}", "events.tip_angle", "finite number"),
        ("bowl}", "bowl}\nevents: {bump_distance: 0.6}", "events.bump_distance", "less than move_distance"),
        ("bowl}", "bowl, require_contact_with: 1}", "success[0].require_contact_with", "true or false"),
        (
            "{predicate: in_container, objects: [banana], container: bowl}",
            "{predicate: upright, objects: [banana], require_contact_with: true}",
            "success[0].require_contact_with",
            "no reference object",
        ),
        (
            "{predicate: in_container, objects: [banana], container: bowl}",
            "{predicate: stacked, objects: [banana]}",
            "success[0].objects",
            "needs at least 2",
        ),
    ],
)
def test_bad_task_values_name_file_field_and_fix(tmp_path, old, new, field, hint):
    assert old in BASE_TASK
    write(tmp_path, "staged", STAGED_SCENE)
    path = write(tmp_path, "T", BASE_TASK.replace(old, new, 1))
    with pytest.raises(SpecError) as error:
        read_task(path)
    assert (error.value.file, error.value.field) == (str(path), field) and hint in str(error.value), str(error.value)


def test_a_file_that_is_not_utf8_names_the_line(tmp_path):
    write(tmp_path, "staged", STAGED_SCENE)
    path = tmp_path / "T.yaml"
    path.write_bytes(BASE_TASK.replace("vague: b", "vague: caf\xe9").encode("latin-1"))
    with pytest.raises(SpecError, match=r"field 'line 4': is not UTF-8 text \(byte 0xe9.*Save the file"):
        read_task(path)


def test_a_key_given_twice_names_the_field_and_both_lines(tmp_path):
    write(tmp_path, "staged", STAGED_SCENE)
    path = write(tmp_path, "T", BASE_TASK + "episode_seconds: 60\n")
    with pytest.raises(SpecError, match=r"field 'episode_seconds': is given twice \(lines 3 and 7\)"):
        read_task(path)
    path = write(tmp_path, "T", BASE_TASK.replace("vague: b", "vague: b, default: d"))
    with pytest.raises(SpecError, match=r"field 'instructions.default': is given twice"):
        read_task(path)


def scene(tmp_path: Path, objects: str, table: str = "{size: [0.9, 1.2]}") -> Path:
    return write(tmp_path, "s", f"name: s\ntable: {table}\njitter: {{xy: 0, yaw_deg: 0}}\nobjects:\n{objects}")


def test_objects_may_not_overlap_unless_one_lies_inside_a_container(tmp_path):
    inside = "  - {name: bowl, asset: bowl_white, xy: [0.5, 0.1]}\n  - {name: cube, asset: block_red, xy: [0.5, 0.1]}\n"
    assert [o.name for o in read_scene(scene(tmp_path, inside)).objects] == ["bowl", "cube"]
    on_plate = (
        "  - {name: plate, asset: plate_white, xy: [0.5, 0.1]}\n  - {name: cube, asset: block_red, xy: [0.5, 0.1]}\n"
    )
    with pytest.raises(SpecError, match=r"'objects\[1\].xy': 'cube' overlaps objects\[0\] 'plate'.*Move them apart"):
        read_scene(scene(tmp_path, on_plate))
    sticking_out = "  - {name: bowl, asset: bowl_white, xy: [0.5, 0.1]}\n  - {name: b, asset: banana, xy: [0.5, 0.2]}\n"
    with pytest.raises(SpecError, match=r"'objects\[1\].xy': 'b' overlaps objects\[0\] 'bowl'"):
        read_scene(scene(tmp_path, sticking_out))


def test_a_table_too_small_for_its_objects_names_the_table_size(tmp_path):
    objects = "  - {name: banana, asset: banana, xy: [0.5, 0.1]}\n"
    with pytest.raises(SpecError, match=r"'table.size\[1\]': the table \(y -0.100..0.100 m\) is too small"):
        read_scene(scene(tmp_path, objects, "{size: [0.3, 0.2]}"))


@pytest.mark.parametrize(
    "table, field, hint",
    [
        ("{rgba: [1.2, 0, 0, 1]}", "table.rgba[0]", "between 0 and 1"),
        ("{size: [0.9, .nan]}", "table.size[1]", "finite number"),
        ("{size: [1.5, 1.2]}", "table.size[0]", "reach the robot's pedestal"),
        ("{size: [0, 1.2]}", "table.size[0]", "must be positive"),
        ("{color: red, rgba: [1, 0, 0, 1]}", "table.rgba", "given together with color"),
    ],
)
def test_bad_table_values_name_file_field_and_fix(tmp_path, table, field, hint):
    path = scene(tmp_path, "  - {name: banana, asset: banana, xy: [0.5, 0.1]}\n", table)
    with pytest.raises(SpecError) as error:
        read_scene(path)
    assert (error.value.file, error.value.field) == (str(path), field) and hint in str(error.value), str(error.value)


def test_every_parameter_and_event_threshold_has_a_range_holding_its_default():
    from robolab_ms.tasks.events import EVENT_THRESHOLDS
    from robolab_ms.tasks.predicates import PREDICATES
    from robolab_ms.tasks.spec import EVENT_LIMITS, PARAM_LIMITS

    ranges = [(f"events.{key}", EVENT_LIMITS[key], default) for key, default in EVENT_THRESHOLDS.items()]
    for name, info in PREDICATES.items():
        for key, default in info.params.items():
            if isinstance(default, float):
                ranges.append((f"{name}.{key}", PARAM_LIMITS.get(f"{name}.{key}") or PARAM_LIMITS[key], default))
    for where, (low, high, above, _), default in ranges:
        assert (low < default if above else low <= default) and default <= high, where


def test_every_robolab_task_has_robolabs_subtask_count_and_difficulty():
    """Subtasks (all: object groups, any: 1, choose K: K, summed over stages), score (subtasks + the largest skill
    weight) and label equal RoboLab-120's task table for every shipped task that is one of RoboLab's."""
    import csv

    with open(Path(__file__).parent / "fixtures" / "robolab120" / "tasks.csv", newline="") as file:
        reference = {row["task"]: row for row in csv.DictReader(file)}
    compared, wrong = 0, []
    for spec in load_all_tasks():
        row = reference.get(spec.name)
        if row is None:
            continue
        compared += 1
        ours = (spec.scene.name, spec.num_subtasks, spec.difficulty_score, spec.difficulty)
        theirs = (row["scene"], int(row["num_subtasks"]), int(row["difficulty_score"]), row["difficulty_label"])
        if ours != theirs:
            wrong.append(f"{spec.name}: ours {ours}, RoboLab's {theirs}")
    assert compared >= 76 and not wrong, "\n".join(wrong)


def test_a_groups_in_containers_stage_counts_its_containers(tmp_path):
    """RoboLab counts the object groups of groups_in_containers: one per container, however many objects it holds."""
    path = write(
        tmp_path,
        "Sort",
        TASK.format(name="Sort", predicate="in_container", obj="banana")
        .replace("scene: banana_bowl", "scene: rubiks_cube_banana_bowl")
        .replace(
            "  - {predicate: in_container, objects: [banana], container: bowl}",
            "  - {predicate: groups_in_containers, groups: {bowl: [banana, rubiks_cube]}}",
        ),
    )
    spec = read_task(path)
    assert len(spec.subtasks[0].objects) == 2 and spec.num_subtasks == 1
