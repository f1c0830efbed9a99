"""vla-eval drives RoboLab-120 (robolab_ms.eval.vla_eval_benchmark): the real `vla-eval run` command, with the
shipped config, against real vla-eval model servers (tests/vla_eval_model_server.py) serving our policies. Episodes
come out as `robolab eval` runs them: the oracle's replayed actions and the random policy give the same success,
score, steps, events and trajectory metrics seed for seed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import anyio
import numpy as np
import pytest
from servers import TESTS, ServerProcess

from robolab_ms.errors import RoboLabError, UnknownNameError
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.eval.vla_eval_benchmark import RoboLabBenchmark
from robolab_ms.policies import PolicyReplyError, make_policy
from robolab_ms.tasks.selection import task_tags
from robolab_ms.tasks.spec import load_task
from robolab_ms.variations import Variations

CONFIG = TESTS.parent / "docs" / "examples" / "vla_eval_robolab120.yaml"
VLA_EVAL = Path(sys.executable).parent / "vla-eval"
TASK = "BananaInBowl"
SCENE = "banana_bowl"  # TASK's scene
DROID_STATE_KEYS = {"observation/joint_position", "observation/gripper_position", "prompt"}
DROID_IMAGE_KEYS = {"observation/exterior_image_1_left", "observation/wrist_image_left"}


class ModelServer(ServerProcess):
    """tests/vla_eval_model_server.py serving one of our policies; `url` is where it listens."""

    def __init__(self, *args: str) -> None:
        super().__init__(
            [sys.executable, str(TESTS / "vla_eval_model_server.py"), *args], ready="vla-eval model server:"
        )
        self.url = self.lines[-1].split()[-1]


def vla_eval_run(server: ModelServer, out: Path, *overrides: str) -> dict:
    """`vla-eval run` with the shipped config against `server`, one task; returns the aggregate result."""
    command = [
        str(VLA_EVAL),
        "run",
        "-c",
        str(CONFIG),
        "--no-docker",
        "--server-url",
        server.url,
        "--output-dir",
        str(out),
        "--param",
        f"tasks=[{TASK}]",
        *overrides,
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-4000:]
    aggregate = json.loads((out / "RoboLab-120_aggregate.json").read_text(encoding="utf-8"))
    assert aggregate["num_errors"] == 0, aggregate["tasks"]
    return aggregate


def served(log: Path) -> list[dict]:
    """What the model server logged: per episode, the task dict and the first observation's keys."""
    return [json.loads(line) for line in log.read_text(encoding="utf-8").splitlines()]


def assert_same_episode(episode: dict, result) -> None:
    """A vla-eval episode and a `robolab eval` result of the same task and seed end the same way."""
    metrics = episode["metrics"]
    assert (metrics["success"], metrics["score"], metrics["progress"], metrics["steps"], metrics["success_step"]) == (
        result.success,
        result.score,
        result.progress,
        result.steps,
        result.success_step,
    )
    assert episode["steps"] == result.steps  # vla-eval's own step count
    assert metrics["seed"] == result.seed and metrics["events"] == result.events
    assert {key: metrics[key] for key in result.metrics} == result.metrics
    assert {key: metrics[key] for key in result.event_counts} == result.event_counts
    assert metrics["clipped_steps"] == result.clipped_steps


@pytest.fixture(scope="module")
def random_server(tmp_path_factory):
    log = tmp_path_factory.mktemp("random_server") / "served.jsonl"
    server = ModelServer("--policy", "random", "--no-images", "--log", str(log))
    server.log = log
    yield server
    server.stop()


@pytest.mark.slow
def test_oracle_actions_replayed_through_vla_eval_end_as_under_robolab_eval(tmp_path):
    oracle = run_evaluation(
        make_policy("oracle"),
        EvalConfig(tasks=(TASK,), episodes=1, first_seed=0, save_actions=True),
        tmp_path / "oracle",
        show_progress=False,
    )[0]
    assert oracle.error is None and oracle.success and oracle.steps < load_task(TASK).max_episode_steps
    log = tmp_path / "served.jsonl"
    server = ModelServer(
        "--policy", "replay", "--replay-from", str(tmp_path / "oracle"), "--no-images", "--log", str(log)
    )
    try:
        aggregate = vla_eval_run(server, tmp_path / "vla-eval", "--benchmark-field", "episodes_per_task=1")
    finally:
        server.stop()
    (task,) = aggregate["tasks"]
    assert_same_episode(task["episodes"][0], oracle)
    assert aggregate["mode"] == "sync" and aggregate["mean_success"] == 1.0 and aggregate["mean_score"] == oracle.score
    assert all(f"mean_{key}" in aggregate for key, value in oracle.metrics.items() if value is not None)
    (episode,) = served(log)
    assert episode["task"]["task"] == TASK and episode["task"]["seed"] == 0 and len(episode["task"]["action_low"]) == 8
    assert set(episode["observation"]) == DROID_STATE_KEYS  # the server asked for no images


@pytest.mark.slow
def test_random_policy_plays_a_full_episode_through_vla_eval(tmp_path, random_server):
    local = run_evaluation(
        make_policy("random"),
        EvalConfig(tasks=(TASK,), episodes=1, first_seed=3),
        tmp_path / "robolab",
        show_progress=False,
    )[0]
    assert local.error is None and local.steps == load_task(TASK).max_episode_steps  # the whole 50 s
    aggregate = vla_eval_run(
        random_server, tmp_path / "vla-eval", "--param", "seed=3", "--benchmark-field", "episodes_per_task=1"
    )
    assert_same_episode(aggregate["tasks"][0]["episodes"][0], local)


@pytest.mark.slow
def test_live_mode_sends_droid_images_and_seeds_episodes_in_turn(tmp_path, random_server):
    start = len(served(random_server.log)) if random_server.log.exists() else 0
    aggregate = vla_eval_run(
        random_server,
        tmp_path / "vla-eval",
        "--param",
        "seed=3",
        "--param",
        "images=true",
        "--benchmark-field",
        "mode=live",
        "--benchmark-field",
        "max_steps=6",
        "--benchmark-field",
        "episodes_per_task=2",
    )
    assert aggregate["mode"] == "live"
    episodes = aggregate["tasks"][0]["episodes"]
    assert [(e["steps"], e["metrics"]["steps"], e["metrics"]["seed"]) for e in episodes] == [(6, 6, 3), (6, 6, 4)]
    logged = served(random_server.log)[start:]
    assert [e["task"]["seed"] for e in logged] == [3, 4]
    for episode in logged:  # the configured images: true wins over the server's request
        observation = episode["observation"]
        assert set(observation) == DROID_STATE_KEYS | DROID_IMAGE_KEYS
        assert all(observation[key] == [[224, 224, 3], "uint8"] for key in DROID_IMAGE_KEYS)
        assert observation["observation/joint_position"] == [[7], "float32"]


def test_tasks_conditions_and_bad_params():
    candidates = [TASK, "PickDrill", "RubiksCubeLeftOfBowl", "RubiksCubeBehindBowl"]
    specs = [load_task(name) for name in candidates]
    for filters, keep in (
        ({"tag": "spatial"}, lambda s: "spatial" in task_tags(s)),
        ({"difficulty": ["simple"]}, lambda s: s.difficulty == "simple"),
        ({"scene": SCENE, "difficulty": "simple"}, lambda s: (s.scene.name, s.difficulty) == (SCENE, "simple")),
    ):
        chosen = [t["name"] for t in RoboLabBenchmark(tasks=candidates, **filters).get_tasks()]
        assert chosen == [s.name for s in specs if keep(s)] and chosen
    with pytest.raises(RoboLabError, match="no task matches tag spatial, difficulty simple"):
        RoboLabBenchmark(tasks=candidates, tag="spatial", difficulty="simple")
    suite = RoboLabBenchmark(tasks=TASK, suite="lighting:dim/bright", vary="objects=0.2", instruction="vague")
    tasks = suite.get_tasks()
    assert [t["name"] for t in tasks] == [f"{TASK}/dim", f"{TASK}/bright"]
    assert tasks[0]["variations"] == Variations.create("objects=0.2,lighting=dim").text
    assert tasks[0]["instruction"] == load_task(TASK).instructions["vague"]
    longest = max(spec.max_episode_steps for spec in specs[:2])
    assert RoboLabBenchmark(tasks=[TASK, "PickDrill"]).get_metadata()["max_steps"] == longest
    assert RoboLabBenchmark(tasks=[TASK, "PickDrill"], max_steps=40).get_metadata()["max_steps"] == 40
    bad = (
        ({"instruction": "odd"}, "params.instruction"),
        ({"seed": "1"}, "params.seed"),
        ({"max_steps": 0}, "params.max_steps"),
        ({"tag": [""]}, "params.tag"),
        ({"suite": ["lighting"]}, "params.suite"),
        ({"tasks": [TASK, TASK]}, "given twice"),
    )
    for params, field in bad:
        with pytest.raises(RoboLabError, match=field):
            RoboLabBenchmark(**{"tasks": TASK, **params})
    with pytest.raises(UnknownNameError, match=TASK):
        RoboLabBenchmark(tasks="BananaInBowls")


def test_hold_action_holds_the_arm_then_the_last_target():
    benchmark = RoboLabBenchmark(tasks=TASK, images=False, max_steps=2, seed=5)
    try:
        home = benchmark.get_hold_action(None)["actions"]
        np.testing.assert_array_equal(home, np.array([*benchmark.robot.home_arm_qpos, 0.0], np.float32))
        task = {**benchmark.get_tasks()[0], "episode_idx": 1}
        anyio.run(benchmark.start_episode, task)
        assert task["seed"] == 6
        hold = benchmark.get_hold_action(None)["actions"]
        np.testing.assert_allclose(hold, home, atol=1e-3)
        last = {"actions": hold + np.float32(0.01)}
        assert benchmark.get_hold_action(last) is last
        with pytest.raises(RoboLabError, match="chunk_size"):
            benchmark.step({"actions": np.zeros((4, 8), np.float32)})
        with pytest.raises(PolicyReplyError, match="8 finite numbers"):
            benchmark.step({"actions": np.full(8, np.nan, np.float32)})
        assert not benchmark.step({"actions": hold}).done
        final = benchmark.step({"actions": hold[None]})
        assert final.done
        metrics = benchmark.get_step_result(final)
        assert (metrics["steps"], metrics["seed"], metrics["success"]) == (2, 6, False)
    finally:
        benchmark.cleanup()
