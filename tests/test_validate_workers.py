"""`robolab validate --workers N`: the rest checks and episodes of several tasks run in worker processes, with the
rows and episodes of a sequential run; a run killed with SIGKILL resumes without running a finished episode again."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import pytest
from helpers import kill_run_with_workers

from robolab_ms.eval.results import EPISODES_FILE, TIMING_FIELDS, EpisodeResult, read_results
from robolab_ms.eval.validate import REPORT_CSV, REPORT_MD, validate_task, write_report

REPO = Path(__file__).resolve().parents[1]
SEEDS = 2
TASK = """
name: {name}
scene: banana_bowl
episode_seconds: {seconds}
attributes: [spatial]
instructions: {{default: Put the banana in the bowl., vague: Tidy up., specific: Put the yellow banana in the bowl.}}
success:
  - {{predicate: in_container, objects: [banana], container: bowl}}
"""
# Ten seconds are enough for the oracle to put the banana in the bowl; in one second it never reaches it, so that
# task's row carries the explanation the oracle's watch sends back from the worker.
TASKS = {"QuickBanana": 10, "HurriedBanana": 1}


def comparable(result: EpisodeResult) -> dict:
    """A result without the fields that measure time."""
    return {key: value for key, value in asdict(result).items() if key not in TIMING_FIELDS}


def report_rows(out: Path) -> list[dict]:
    """validation.csv without the oracle's time per episode."""
    return [{**row, "oracle_seconds": None} for row in csv.DictReader((out / REPORT_CSV).open())]


def complete_lines(out: Path) -> list[str]:
    lines = []
    for line in (out / EPISODES_FILE).read_text(encoding="utf-8").splitlines():
        try:
            json.loads(line)
        except json.JSONDecodeError:
            continue
        lines.append(line)
    return lines


@pytest.fixture(scope="module")
def task_files(tmp_path_factory) -> list[str]:
    folder = tmp_path_factory.mktemp("tasks")
    paths = []
    for name, seconds in TASKS.items():
        path = folder / f"{name}.yaml"
        path.write_text(TASK.format(name=name, seconds=seconds))
        paths.append(str(path))
    return paths


@pytest.fixture(scope="module")
def sequential(tmp_path_factory, task_files) -> Path:
    """The reference: the tasks validated one after another in this process, as `robolab validate` does by default."""
    out = tmp_path_factory.mktemp("sequential")
    write_report([validate_task(task, SEEDS, out, show_progress=False) for task in task_files], out)
    return out


def validate_command(task_files: list[str], out: Path) -> list[str]:
    return [
        sys.executable,
        "-m",
        "robolab_ms.cli",
        "validate",
        "--task",
        *task_files,
        "--seeds",
        str(SEEDS),
        "--out",
        str(out),
        "--workers",
        "2",
        "--quiet",
    ]


def run_validate(task_files: list[str], out: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        validate_command(task_files, out),
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )


def assert_same_as_sequential(out: Path, sequential: Path) -> None:
    assert {r.key(): comparable(r) for r in read_results(out)} == {
        r.key(): comparable(r) for r in read_results(sequential)
    }
    rows = report_rows(out)
    assert rows == report_rows(sequential)
    assert [row["task"] for row in rows] == list(TASKS), "rows in task order"
    assert rows[1]["oracle_failures"] == (
        "seed 0, 1: ran out of time (15 steps): banana never grasped (the fingers never touched it)"
    )


@pytest.mark.slow
def test_two_workers_give_the_rows_and_episodes_of_a_sequential_run(tmp_path, task_files, sequential):
    out = tmp_path / "parallel"
    result = run_validate(task_files, out)
    assert result.returncode == 1, result.stdout + result.stderr  # HurriedBanana fails: the oracle has no time
    assert "failed validation: HurriedBanana" in result.stderr and "Traceback" not in result.stderr
    assert len(complete_lines(out)) == 2 * SEEDS * len(TASKS)
    assert_same_as_sequential(out, sequential)
    markdown = (out / REPORT_MD).read_text()
    assert markdown.index("| QuickBanana |") < markdown.index("| HurriedBanana |")


@pytest.mark.slow
def test_a_run_killed_mid_way_resumes_without_running_finished_episodes_again(tmp_path, task_files, sequential):
    out = tmp_path / "killed"
    log = (tmp_path / "killed.log").open("w")
    process = subprocess.Popen(
        validate_command(task_files, out),
        stdout=log,
        stderr=subprocess.STDOUT,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    kill_run_with_workers(
        process, lambda: len(complete_lines(out)) if (out / EPISODES_FILE).exists() else 0, 2, tmp_path / "killed.log"
    )
    before = complete_lines(out)
    assert 2 <= len(before) < 2 * SEEDS * len(TASKS)

    result = run_validate(task_files, out)
    assert result.returncode == 1, result.stdout + result.stderr
    after = complete_lines(out)
    assert after[: len(before)] == before, "the lines written before the kill stay as they were"
    keys = [tuple(json.loads(line)[key] for key in ("task", "policy", "seed")) for line in after]
    assert len(keys) == len(set(keys)) == 2 * SEEDS * len(TASKS), "every episode exactly once"
    assert_same_as_sequential(out, sequential)


def test_workers_must_be_at_least_one(capsys):
    from robolab_ms.cli import main

    assert main(["validate", "--task", "BananaInBowl", "--workers", "0"]) == 2
    assert "--workers must be at least 1, got 0" in capsys.readouterr().err
