"""The rest check of `robolab validate` counts a task as solved at reset when its condition holds right after reset
or once the objects have settled untouched (they start a few millimetres above their supports)."""

from __future__ import annotations

from pathlib import Path

from robolab_ms.eval.validate import check_rest

TASK = """
name: {name}
scene: banana_bowl
episode_seconds: 10
attributes: [spatial]
instructions: {{default: Do it., vague: Do it., specific: Do it.}}
success:
  - {condition}
"""
ON_TABLE = "{predicate: outside_of_and_on_surface, objects: [banana], container: bowl, surface: table}"
IN_BOWL = "{predicate: in_container, objects: [banana], container: bowl}"


def write_task(folder: Path, name: str, condition: str) -> str:
    path = folder / f"{name}.yaml"
    path.write_text(TASK.format(name=name, condition=condition))
    return str(path)


def test_a_condition_that_holds_once_the_objects_settle_counts_as_solved_at_reset(tmp_path):
    drift, solved = check_rest(write_task(tmp_path, "BananaStaysOnTable", ON_TABLE), range(1))
    assert solved == 1 and drift < 0.02


def test_a_condition_that_needs_the_robot_is_not_solved_at_rest(tmp_path):
    drift, solved = check_rest(write_task(tmp_path, "BananaIntoBowl", IN_BOWL), range(1))
    assert solved == 0 and drift < 0.02
