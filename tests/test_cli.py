"""The `robolab` command, end to end, as a user runs it."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROBOLAB = str(Path(sys.executable).with_name("robolab"))


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOLAB, *args], capture_output=True, text=True, cwd=cwd, timeout=600)


def test_list_shows_tasks_with_difficulty():
    result = run("list")
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    assert "BananaInBowl" in result.stdout and "RoboLab-BananaInBowl-v1" in result.stdout
    assert "simple (1)" in result.stdout


def test_eval_writes_episodes_and_summary_and_resumes(tmp_path):
    out = tmp_path / "run"
    args = (
        "eval",
        "--policy",
        "random",
        "--task",
        "BananaInBowl",
        "--episodes",
        "2",
        "--max-steps",
        "10",
        "--out",
        str(out),
    )
    first = run(*args)
    assert first.returncode == 0, first.stderr
    lines = (out / "episodes.jsonl").read_text().splitlines()
    episodes = [json.loads(line) for line in lines]
    assert [e["seed"] for e in episodes] == [0, 1]
    assert all(e["steps"] == 10 and e["task"] == "BananaInBowl" and e["error"] is None for e in episodes)
    summary = (out / "summary.md").read_text()
    assert "success_%" in summary and "BananaInBowl" in summary
    assert (out / "summary.csv").exists() and (out / "manifest.json").exists()
    assert "%" in first.stderr  # the progress bar

    with (out / "episodes.jsonl").open("a") as handle:
        handle.write('{"task": "BananaInBo')  # an interrupted write
    three = list(args)
    three[three.index("--episodes") + 1] = "3"  # only seed 2 is new
    again = run(*three)
    assert again.returncode == 0, again.stderr
    seeds = [
        json.loads(line)["seed"] for line in (out / "episodes.jsonl").read_text().splitlines() if line.endswith("}")
    ]
    assert seeds == [0, 1, 2]


def test_unknown_task_is_a_one_line_error_with_a_suggestion(tmp_path):
    result = run("eval", "--task", "BananaInBowel", "--out", str(tmp_path))
    assert result.returncode == 2
    assert "Did you mean 'BananaInBowl'" in result.stderr
    assert "Traceback" not in result.stderr


def test_unknown_policy_is_reported():
    result = run("eval", "--policy", "randm", "--task", "BananaInBowl")
    assert result.returncode == 2 and "Did you mean 'random'?" in result.stderr


def test_eval_runs_the_droid_robot_by_default_and_names_an_unknown_one(tmp_path):
    result = run(
        "eval", "--task", "BananaInBowl", "--episodes", "1", "--max-steps", "3", "--out", str(tmp_path), "--quiet"
    )
    assert result.returncode == 0, result.stderr
    assert json.loads((tmp_path / "episodes.jsonl").read_text().splitlines()[0])["robot"] == "droid"
    result = run("eval", "--task", "BananaInBowl", "--robot", "pandaa", "--out", str(tmp_path))
    assert result.returncode == 2 and "Did you mean 'panda'" in result.stderr, result.stderr


@pytest.mark.slow
def test_policy_name_files_results_under_another_name(tmp_path):
    out = tmp_path / "named"
    result = run(
        "eval",
        "--policy",
        "hold",
        "--policy-name",
        "hold-v2",
        "--task",
        "BananaInBowl",
        "--episodes",
        "1",
        "--max-steps",
        "3",
        "--out",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    episode = json.loads((out / "episodes.jsonl").read_text())
    assert episode["policy"] == "hold-v2"
    rerun = json.loads((out / "manifest.json").read_text())["rerun"]
    assert "--policy hold --policy-name hold-v2" in rerun
    blank = run("eval", "--policy", "hold", "--policy-name", " ", "--task", "BananaInBowl", "--out", str(tmp_path))
    assert blank.returncode == 2 and "--policy-name" in blank.stderr and "Traceback" not in blank.stderr
