"""Parallel and distributed runs: `robolab eval --workers N` (killed with SIGKILL and resumed) and `--ray ADDRESS`
on a local Ray instance give every episode exactly once, with the results of a plain sequential run."""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path
from types import SimpleNamespace

import h5py
import pytest
from helpers import kill_run_with_workers
from tqdm import tqdm

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.results import EPISODES_FILE, TIMING_FIELDS, EpisodeResult, exclusive_writer, read_results
from robolab_ms.eval.runner import EvalConfig, adaptive_sampling_done, run_evaluation
from robolab_ms.eval.schedule import Job, Schedule
from robolab_ms.policies import make_policy

ROBOLAB = str(Path(sys.executable).with_name("robolab"))
TESTS = Path(__file__).parent
TASKS = ("BananaInBowl", "BananaOnPlate")
EPISODES, MAX_STEPS = 5, 6


def comparable(result: EpisodeResult) -> dict:
    """A result without the fields that measure time."""
    return {key: value for key, value in asdict(result).items() if key not in TIMING_FIELDS}


def complete_lines(out: Path) -> list[dict]:
    lines = []
    for line in (out / EPISODES_FILE).read_text(encoding="utf-8").splitlines():
        try:
            lines.append(json.loads(line))
        except json.JSONDecodeError:
            pass
    return lines


@pytest.fixture(scope="module")
def sequential(tmp_path_factory) -> dict[tuple, dict]:
    """The reference: the same episodes run one after another in this process."""
    out = tmp_path_factory.mktemp("sequential")
    config = EvalConfig(tasks=TASKS, episodes=EPISODES, max_steps=MAX_STEPS)
    return {r.key(): comparable(r) for r in run_evaluation(make_policy("random"), config, out, show_progress=False)}


def eval_command(out: Path, *extra: str) -> list[str]:
    return [
        ROBOLAB,
        "eval",
        "--policy",
        "random",
        "--task",
        *TASKS,
        "--episodes",
        str(EPISODES),
        "--max-steps",
        str(MAX_STEPS),
        "--out",
        str(out),
        "--quiet",
        *extra,
    ]


@pytest.mark.slow
def test_workers_killed_by_sigkill_mid_run_resume_with_every_episode_once(tmp_path, sequential):
    out = tmp_path / "run"
    log = (tmp_path / "killed.log").open("w")
    process = subprocess.Popen(eval_command(out, "--workers", "2"), stdout=log, stderr=subprocess.STDOUT)
    episodes = out / EPISODES_FILE
    kill_run_with_workers(
        process, lambda: len(complete_lines(out)) if episodes.exists() else 0, 3, tmp_path / "killed.log"
    )
    written = len(complete_lines(out))
    assert 3 <= written < len(TASKS) * EPISODES
    with episodes.open("a", encoding="utf-8") as handle:  # as if the kill had come in the middle of a line
        handle.write('{"task": "BananaInBowl", "seed": 4, "succ')

    rerun = subprocess.run(eval_command(out, "--workers", "2"), capture_output=True, text=True, timeout=600)
    assert rerun.returncode == 0, rerun.stdout + rerun.stderr

    lines = complete_lines(out)
    keys = [(line["task"], line["instruction_variant"], line["robot"], line["policy"], line["seed"]) for line in lines]
    assert sorted(keys) == sorted(sequential), "every episode exactly once"
    assert {r.key(): comparable(r) for r in read_results(out)} == sequential
    assert "BananaOnPlate" in (out / "summary.md").read_text()


@pytest.mark.slow
def test_ray_actors_on_a_local_instance_stream_results_and_recordings_back(tmp_path, sequential):
    environment = {**os.environ, "RAY_AUTH_MODE": "disabled"}  # a test instance on 127.0.0.1: no tokens
    head = subprocess.Popen(
        [sys.executable, str(TESTS / "ray_head.py"), "2"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=environment,
    )
    try:
        line = head.stdout.readline()
        assert line.startswith("ray-address "), f"the Ray instance did not start: {line!r}"
        address = line.split()[1]
        out = tmp_path / "ray"
        command = [
            ROBOLAB,
            "eval",
            "--policy",
            "random",
            "--task",
            TASKS[0],
            "--episodes",
            "3",
            "--max-steps",
            str(MAX_STEPS),
            "--out",
            str(out),
            "--quiet",
            "--ray",
            address,
            "--workers",
            "2",
            "--record",
        ]
        run = subprocess.run(command, capture_output=True, text=True, timeout=600, env=environment)
        assert run.returncode == 0, run.stdout + run.stderr
    finally:
        head.stdin.close()
        try:
            head.wait(timeout=60)
        except subprocess.TimeoutExpired:
            head.kill()
    results = read_results(out)
    assert len(complete_lines(out)) == 3
    assert {r.key(): {**comparable(r), "recording": None} for r in results} == {
        key: value for key, value in sequential.items() if key[0] == TASKS[0] and key[4] < 3
    }
    for result in results:  # the actors' files came back into the one results folder
        recording = out / result.recording
        with h5py.File(recording, "r") as file:
            assert file["traj_0/actions"].shape == (MAX_STEPS, 8)
        meta = json.loads(recording.with_suffix(".json").read_text())
        assert meta["robolab"]["seed"] == result.seed and meta["episodes"][0]["success"] == result.success
    assert not list(out.rglob("*.partial"))


@pytest.mark.slow
def test_a_worker_that_cannot_reach_its_policy_server_stops_the_run_with_the_one_line_error(tmp_path):
    from servers import free_port

    port = free_port()  # nothing listens there
    run = subprocess.run(
        [
            ROBOLAB,
            "eval",
            "--policy",
            "openpi",
            "--port",
            str(port),
            "--task",
            TASKS[0],
            "--episodes",
            "2",
            "--workers",
            "2",
            "--out",
            str(tmp_path),
            "--quiet",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 2, run.stdout + run.stderr
    assert run.stderr.startswith(f"robolab: error: no openpi policy server answers at 127.0.0.1:{port}")
    assert "Traceback" not in run.stderr
    assert not (tmp_path / EPISODES_FILE).exists()


def test_a_second_run_on_the_same_folder_is_refused_until_the_first_ends(tmp_path):
    with exclusive_writer(tmp_path):
        with pytest.raises(RoboLabError, match="is being written by robolab eval"):
            with exclusive_writer(tmp_path):
                pass
    with exclusive_writer(tmp_path):
        pass


def _sequential_adaptive(successes: dict[int, bool], max_n: int, width: float, first: int = 0) -> list[int]:
    """The seeds the sequential runner keeps for one task."""
    kept, wins = [], 0
    for seed in range(first, first + max_n):
        if adaptive_sampling_done(wins, len(kept), max_n, width):
            break
        kept.append(seed)
        wins += successes[seed]
    return kept


def _fake_result(task: str, seed: int, success: bool, out: Path) -> EpisodeResult:
    recording = f"recordings/{task}/default-droid-random-seed{seed}.h5"
    (out / recording).parent.mkdir(parents=True, exist_ok=True)
    (out / recording).write_bytes(b"h5")
    return EpisodeResult(
        task=task,
        instruction_variant="default",
        instruction="-",
        robot="droid",
        policy="random",
        seed=seed,
        success=success,
        score=float(success),
        progress=0.0,
        steps=1,
        max_steps=1,
        success_step=None,
        wall_seconds=0.0,
        recording=recording,
    )


@pytest.mark.parametrize("workers", [2, 5])
@pytest.mark.parametrize("rate", [0.0, 0.5, 0.9])
def test_adaptive_episodes_with_workers_keep_exactly_the_sequential_seeds(tmp_path, workers, rate):
    """Results arrive in any order; the kept episodes (and only their files) are the sequential run's."""
    rng = random.Random(f"{workers}-{rate}")
    tasks = ("A", "B")
    max_n, width = 60, 0.3
    wins = {task: {seed: rng.random() < rate for seed in range(max_n)} for task in tasks}
    done_before = [_fake_result("B", seed, wins["B"][seed], tmp_path) for seed in (0, 1, 2, 13)]  # a resumed run
    for result in done_before:
        from robolab_ms.eval.results import append_result

        append_result(tmp_path, result)
    config = EvalConfig(tasks=tasks, episodes_adaptive=max_n, ci_width=width, robot="droid")
    specs = [SimpleNamespace(name=task) for task in tasks]
    schedule = Schedule(config, specs, "random", tmp_path, workers, tqdm(total=2 * max_n, disable=True))
    running: list[tuple[int, Job]] = []
    current: dict[int, str | None] = {index: None for index in range(workers)}
    while True:
        for index in range(workers):
            if all(index != busy for busy, _ in running):
                job = schedule.next_job(current[index])
                if job is not None:
                    running.append((index, job))
                    current[index] = job.name
        if not running:
            break
        index, job = running.pop(rng.randrange(len(running)))
        schedule.take(job, _fake_result(job.task, job.seed, wins[job.task][job.seed], tmp_path))
    assert schedule.finished()
    lines = complete_lines(tmp_path)
    keys = [(line["task"], line["seed"]) for line in lines]
    assert len(keys) == len(set(keys)), "an episode was written twice"
    for task in tasks:
        expected = _sequential_adaptive(wins[task], max_n, width)
        kept = sorted(seed for name, seed in keys if name == task)
        extra = [13] if task == "B" and 13 not in expected else []  # what a previous run left stays
        assert kept == sorted(expected + extra)
        files = sorted(int(path.stem.rsplit("seed", 1)[1]) for path in (tmp_path / "recordings" / task).glob("*.h5"))
        assert files == kept
