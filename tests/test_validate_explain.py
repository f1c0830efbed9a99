"""`robolab validate` says why the oracle failed an episode that ran out of time: never grasped, dropped, still held,
placed but the condition false, placed but a flag unmet, fell off the table."""

import csv
import os
import subprocess
import sys
from pathlib import Path

from robolab_ms.eval.results import EpisodeResult
from robolab_ms.eval.validate import (
    ContactEnd,
    EpisodeWatch,
    FinalState,
    WatchedPolicy,
    explain_failure,
    group_explanations,
)
from robolab_ms.tasks.spec import load_task

REPO = Path(__file__).resolve().parents[1]

TASK = """
name: {name}
scene: banana_bowl
episode_seconds: {seconds}
attributes: [spatial]
instructions: {{default: Put the banana in the bowl., vague: Tidy up., specific: Put the yellow banana in the bowl.}}
success:
  - {condition}
"""


def write_task(folder: Path, name: str, seconds: float, condition: str) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(TASK.format(name=name, seconds=seconds, condition=condition))
    return path


def test_validate_reports_why_the_oracle_ran_out_of_time(tmp_path):
    """One second (15 steps) is too short for the oracle to reach the banana: the terminal, validation.md and
    validation.csv say it was never grasped."""
    path = write_task(tmp_path, "HurriedBanana", 1, "{predicate: in_container, objects: [banana], container: bowl}")
    out = tmp_path / "validate"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "robolab_ms.cli",
            "validate",
            "--task",
            str(path),
            "--seeds",
            "1",
            "--out",
            str(out),
            "--quiet",
        ],
        capture_output=True,
        text=True,
        timeout=900,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    assert result.returncode == 1, result.stderr[-3000:]
    why = "seed 0: ran out of time (15 steps): banana never grasped (the fingers never touched it)"
    assert f"why the oracle failed HurriedBanana: {why}" in result.stdout
    (row,) = csv.DictReader((out / "validation.csv").open())
    assert row["task"] == "HurriedBanana" and row["oracle_failures"] == why and row["oracle_errors"] == ""
    assert why in (out / "validation.md").read_text()
    assert "failed validation: HurriedBanana" in result.stderr and "Traceback" not in result.stderr


def test_a_placement_the_condition_rejects_is_explained(tmp_path):
    """The oracle puts the banana in the bowl, but no placement is within 10 micrometres of the bowl's centre."""
    import robolab_ms.envs
    from robolab_ms.eval.runner import EvalConfig, run_evaluation
    from robolab_ms.policies import make_policy

    path = write_task(
        tmp_path, "ExactlyCentred", 10, "{predicate: on_center, objects: [banana], reference: bowl, tolerance: 0.00001}"
    )
    spec = load_task(path)
    robolab_ms.envs.register_task_file(spec.file)
    oracle = WatchedPolicy(make_policy("oracle"))
    (episode,) = run_evaluation(oracle, EvalConfig(tasks=(str(path),), episodes=1), tmp_path / "run", False)
    assert not episode.success and episode.error is None and episode.steps == 150
    watch = oracle.watches[0]
    assert watch.touched == {"banana"} and watch.final is not None and watch.final.held == []
    why = explain_failure(episode, watch, spec)
    assert why.startswith("ran out of time (150 steps): banana placed (let go at step "), why
    assert "but on_center(banana, reference=bowl) false at the end" in why


def _episode(steps: int = 750, error: str | None = None, events: list | None = None) -> EpisodeResult:
    return EpisodeResult(
        task="BananaInBowl",
        instruction_variant="default",
        instruction="x",
        robot="droid",
        policy="oracle",
        seed=3,
        success=False,
        score=0.0,
        progress=0.0,
        steps=steps,
        max_steps=steps,
        success_step=None,
        wall_seconds=1.0,
        error=error,
        events=events or [],
    )


def _watch(touched=("banana",), ends=(), holds=False, placed=False, held=(), height=0.03) -> EpisodeWatch:
    final = FinalState([{"banana": holds}], [{"banana": placed}], list(held), {"banana": height})
    return EpisodeWatch(3, set(touched), list(ends), final)


def test_each_way_of_failing_gets_its_own_explanation():
    spec = load_task("BananaInBowl")  # in_container(banana, container=bowl), require_contact_with and _detached
    condition = "in_container(banana, container=bowl)"
    assert explain_failure(_episode(), _watch(touched=()), spec) == (
        "ran out of time (750 steps): banana never grasped (the fingers never touched it)"
    )
    dropped = _watch(ends=[ContactEnd(40, "banana", False, 0.03), ContactEnd(80, "banana", True, 0.21)])
    assert explain_failure(_episode(), dropped, spec) == (
        f"ran out of time (750 steps): banana dropped at step 80 (slipped out of the closed gripper 21 cm above the "
        f"table); {condition} false at the end"
    )
    released = _watch(ends=[ContactEnd(80, "banana", True, 0.21), ContactEnd(120, "banana", False, 0.1)])
    assert explain_failure(_episode(), released, spec) == (
        f"ran out of time (750 steps): banana placed (let go at step 120 after 1 drop(s)) but {condition} false at "
        "the end"
    )
    assert explain_failure(_episode(), _watch(placed=True, held=["banana"]), spec) == (
        "ran out of time (750 steps): banana still held at the end; the placement is right, but "
        "require_gripper_detached needs it let go of"
    )
    assert explain_failure(_episode(), _watch(placed=True), spec) == (
        "ran out of time (750 steps): banana placed, but not touching bowl (require_contact_with) at the end"
    )
    fell = explain_failure(_episode(), _watch(height=-0.7), spec)
    assert fell == "ran out of time (750 steps): banana fell off the table"
    wrong = [
        {"step": 30, "type": "wrong_object_grasped", "object": "apple"},
        {"step": 90, "type": "wrong_object_grasped", "object": "apple"},
    ]
    assert explain_failure(_episode(events=wrong), _watch(touched=()), spec).endswith(
        "[events: wrong_object_grasped apple @30 (x2)]"
    )
    error = "OracleFailure: no motion plan"
    assert explain_failure(_episode(error=error), None, spec) == error
    assert explain_failure(_episode(events=wrong), None, spec) == (
        "no success in 750 steps; events: wrong_object_grasped apple @30 (x2)"
    )  # a resumed episode: events only
    assert group_explanations([(1, "a"), (4, "b"), (7, "a")]) == "seed 1, 7: a; seed 4: b"
