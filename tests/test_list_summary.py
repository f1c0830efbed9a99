"""`robolab list --summary`: RoboLab-120's totals as RoboLab reports them, ours counted from the task files, and
every task we share with RoboLab carrying RoboLab's facts. No simulation."""

from __future__ import annotations

import csv
import io
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest
import yaml

from robolab_ms.content import content_dir
from robolab_ms.tasks.spec import load_all_tasks
from robolab_ms.tasks.summary import (
    facts_of_spec,
    robolab_facts,
    select_facts,
    summarize,
    task_differences,
    totals,
)

FIXTURES = Path(__file__).parent / "fixtures" / "robolab120"
PARKED_BELOW = -1.0  # m: RoboLab parks unused bodies far below the floor (as in test_robolab_layouts)

# RoboLab-120 as RoboLab reports it (issue 15 and the reference facts).
ROBOLAB_ATTRIBUTES = {
    "semantics": 60,
    "color": 26,
    "size": 6,
    "spatial": 29,
    "conjunction": 8,
    "counting": 7,
    "affordance": 12,
    "sorting": 12,
    "stacking": 6,
    "reorientation": 6,
}
ROBOLAB_AXES = {"visual": 84, "relational": 42, "procedural": 34}
ROBOLAB_DIFFICULTY = {"simple": 64, "moderate": 39, "complex": 17}
# Independent of the code under test: attribute -> axis, skill weights, as RoboLab defines them.
AXIS = {"color": "visual", "semantics": "visual", "size": "visual", "conjunction": "relational",
        "counting": "relational", "spatial": "relational", "affordance": "procedural",
        "reorientation": "procedural", "stacking": "procedural", "sorting": "procedural"}  # fmt: skip
WEIGHT = {"spatial": 1, "counting": 2, "sorting": 2, "stacking": 2, "affordance": 2, "reorientation": 3}


@pytest.fixture(scope="module")
def ours():
    return [facts_of_spec(spec) for spec in load_all_tasks()]


@pytest.fixture(scope="module")
def theirs():
    return robolab_facts()


def section(counts: dict, name: str) -> dict:
    return {item: value for (kind, item), value in counts.items() if kind == name}


def test_robolab_side_is_robolab_120(theirs):
    counts = totals(theirs)
    assert counts[("benchmark", "tasks")] == 120 and counts[("benchmark", "scenes")] == 47
    attributes = section(counts, "attribute")
    assert {name: attributes[name] for name in ROBOLAB_ATTRIBUTES} == ROBOLAB_ATTRIBUTES
    assert section(counts, "axis") == ROBOLAB_AXES
    assert section(counts, "difficulty") == ROBOLAB_DIFFICULTY
    lengths = {float(seconds): n for seconds, n in section(counts, "episode_seconds").items()}
    assert sum(lengths.values()) == 120 and min(lengths) == 20 and max(lengths) == 300
    assert max(lengths, key=lengths.get) == 60  # most tasks last 60 s
    objects = section(counts, "objects_per_task")
    assert round(objects["mean"], 1) == 9.2 and objects["min"] == 2 and objects["max"] == 19


def test_robolab_facts_agree_with_the_reference_fixtures(theirs):
    """The package's copy of RoboLab's table equals the test fixtures' (tasks.csv: scene, subtasks, difficulty;
    scenes.csv: the bodies of each scene we ship, parked ones left out)."""
    with open(FIXTURES / "tasks.csv", newline="") as file:
        table = {
            row["task"]: (row["scene"], int(row["num_subtasks"]), int(row["difficulty_score"]), row["difficulty_label"])
            for row in csv.DictReader(file)
        }
    assert {t.name: (t.scene, t.subtasks, t.difficulty_score, t.difficulty) for t in theirs} == table
    with open(FIXTURES / "scenes.csv", newline="") as file:
        bodies = Counter(row["scene"] for row in csv.DictReader(file) if float(row["z"]) > PARKED_BELOW)
    objects = {t.scene: t.objects for t in theirs}
    assert len(bodies) >= 41 and {scene: objects[scene] for scene in bodies} == dict(bodies)


def subtasks_from_yaml(task: dict) -> int:
    """RoboLab's subtask count, read straight from a task file: per stage, `all` counts its object groups (the
    containers of a groups_in_containers step, else its objects), `any` 1, `choose` K."""
    stages = task.get("subtasks") or [task["success"][0]]
    count = 0
    for stage in stages:
        steps = stage.get("steps", [stage])
        groups = next((step["groups"] for step in steps if "groups" in step), None)
        objects = stage.get("objects") or [name for members in (groups or {}).values() for name in members]
        logical = stage.get("logical", "all")
        if groups is not None or stage.get("predicate") == "placed_in_container_in_order":
            logical = "all"  # the group predicates judge all their objects together
        if logical == "any":
            count += 1
        elif logical == "choose":
            count += stage["k"]
        elif groups is not None:
            count += sum(1 for members in groups.values() if set(members) & set(objects))
        else:
            count += len(objects)
    return count


def test_our_side_equals_counts_from_the_task_files(ours):
    files = sorted(content_dir("tasks").glob("*.yaml"))
    tasks = [yaml.safe_load(path.read_text(encoding="utf-8")) for path in files]
    scenes = {
        path.stem: yaml.safe_load(path.read_text(encoding="utf-8")) for path in content_dir("scenes").glob("*.yaml")
    }
    attributes = Counter(a for task in tasks for a in task["attributes"] if a in AXIS)
    axes = Counter(axis for task in tasks for axis in {AXIS[a] for a in task["attributes"] if a in AXIS})
    difficulty = Counter()
    for task in tasks:
        score = subtasks_from_yaml(task) + max((WEIGHT.get(a, 0) for a in task["attributes"]), default=0)
        difficulty["simple" if score <= 2 else "moderate" if score <= 4 else "complex"] += 1
    lengths = Counter(f"{float(task['episode_seconds']):g}" for task in tasks)
    objects = [len(scenes[task["scene"]]["objects"]) for task in tasks]

    counts = totals(ours)
    assert counts[("benchmark", "tasks")] == len(tasks) >= 106
    assert counts[("benchmark", "scenes")] == len({task["scene"] for task in tasks})
    assert {k: v for k, v in section(counts, "attribute").items() if k in AXIS} == dict(attributes)
    assert section(counts, "axis") == dict(axes)
    assert section(counts, "difficulty") == dict(difficulty)
    assert section(counts, "episode_seconds") == dict(lengths)
    assert section(counts, "objects_per_task") == pytest.approx(
        {"mean": sum(objects) / len(objects), "min": min(objects), "max": max(objects)}
    )


def test_every_shared_task_has_robolabs_scene_length_attributes_and_difficulty(ours, theirs):
    shared = {t.name for t in ours} & {t.name for t in theirs}
    assert len(shared) >= 106
    wrong = [d for d in task_differences(ours, theirs) if d[1] != "objects"]
    assert not wrong, "\n".join(f"{task}: {key} ours {mine}, RoboLab's {other}" for task, key, mine, other in wrong)


def test_every_shared_task_has_as_many_objects_as_robolabs_scene(ours, theirs):
    wrong = [d for d in task_differences(ours, theirs) if d[1] == "objects"]
    assert not wrong, "\n".join(f"{task}: ours {mine}, RoboLab's {other}" for task, _, mine, other in wrong)


def test_the_summary_shows_missing_tasks_and_differences(theirs):
    """Two of RoboLab's tasks, one of them changed and one left out: the rows, the missing task and the
    differing fields come out."""
    banana, plate = (next(t for t in theirs if t.name == name) for name in ("BananaInBowl", "BananaOnPlate"))
    changed = type(banana)(
        **{
            **banana.__dict__,
            "attributes": ("semantics", "spatial"),
            "difficulty_score": 2,
            "objects": banana.objects + 1,
        }
    )
    summary = summarize([changed], [banana, plate])
    rows = {(row.section, row.item): row for row in summary.rows}
    assert (rows[("benchmark", "tasks")].ours, rows[("benchmark", "tasks")].robolab) == (1, 2)
    assert rows[("attribute", "spatial")].difference == 1 and rows[("axis", "relational")].robolab == 0
    assert summary.missing == ("BananaOnPlate",) and summary.extra == ()
    assert {(task, key) for task, key, _, _ in summary.task_differences} == {
        ("BananaInBowl", "attributes"),
        ("BananaInBowl", "difficulty"),
        ("BananaInBowl", "objects"),
    }
    assert len(select_facts(theirs, tags=["relational"])) == 42
    assert len(select_facts(theirs, names=["BananaInBowl", "Nope"], difficulties=["simple"])) == 1


def run_list(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "robolab_ms.cli", "list", *args], capture_output=True, text=True, timeout=300
    )


@pytest.mark.slow
def test_list_summary_command_prints_both_sides():
    result = run_list("--summary", "--format", "csv")
    assert result.returncode == 0, result.stderr
    rows = {(row["section"], row["item"]): row for row in csv.DictReader(io.StringIO(result.stdout))}
    assert {item: int(rows[("attribute", item)]["robolab"]) for item in ROBOLAB_ATTRIBUTES} == ROBOLAB_ATTRIBUTES
    assert {item: int(rows[("difficulty", item)]["robolab"]) for item in ROBOLAB_DIFFICULTY} == ROBOLAB_DIFFICULTY
    tasks = rows[("benchmark", "tasks")]
    missing = [row for row in rows.values() if row["section"] == "missing_task"]
    assert tasks["robolab"] == "120" and int(tasks["ours"]) - 120 == int(tasks["difference"]) == -len(missing)

    text = run_list("--summary", "--tag", "spatial")
    assert text.returncode == 0, text.stderr
    lines = {line.split()[0]: line.split()[1:] for line in text.stdout.splitlines() if line.startswith("  ")}
    assert lines["spatial"][1] == "29" and lines["tasks"][1] == "29"
    assert "of RoboLab's 29 task(s) are not among ours" in text.stdout or "missing: none" in text.stdout


def test_format_without_summary_is_refused():
    result = run_list("--format", "csv")
    assert result.returncode == 2 and "add --summary" in result.stderr and "Traceback" not in result.stderr
