"""Real-time evaluation (`robolab eval --realtime`): a policy server that answers 0.4 s late, an episode whose arm
goes on with its chunk and holds while the server thinks, actions that arrive late skipped as stale; a fast server
asked every open-loop horizon; in-process policies refused; `robolab serve --delay-ms`."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from fault_server import HORIZON, timed_target
from servers import fault_server, free_port

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import HoldPolicy, PolicyOptions, make_policy
from robolab_ms.policies.replay import actions_file
from robolab_ms.policies.server import PolicySession
from robolab_ms.tasks.spec import CONTROL_HZ

ROBOLAB = str(Path(sys.executable).with_name("robolab"))
DELAY = 0.4  # s: every reply; at 15 Hz at least 6 control steps
OPEN_LOOP_HORIZON = 2  # the client asks every 2 steps, or as soon as a slower reply is in
STEPS = 30
SEED = 0


def _expected_held(request_steps: list[int], steps: int) -> set[int]:
    """The steps without an action, by the definition (docs/policies.md) and the steps the server saw: request i
    carries the observation of step k_i; as every reply takes longer than the open-loop horizon, the next request
    goes out at the step its reply arrives, k_(i+1). From then on its chunk (action j for step k_i + j) is the
    current one; the last request is still in flight when the episode ends."""
    held = set()
    for step in range(steps):
        arrived = [i for i in range(len(request_steps) - 1) if request_steps[i + 1] <= step]
        if not arrived or step - request_steps[arrived[-1]] >= HORIZON:
            held.add(step)
    return held


def test_a_slow_server_makes_the_arm_hold_and_late_actions_are_skipped(tmp_path):
    port = free_port()
    log = tmp_path / "requests.jsonl"
    server = fault_server("openpi", port, {SEED: "timed"}, log, delay=DELAY)
    config = EvalConfig(tasks=("BananaInBowl",), episodes=1, first_seed=SEED, max_steps=STEPS, save_actions=True)
    options = PolicyOptions(port=port, open_loop_horizon=OPEN_LOOP_HORIZON, realtime=True)
    try:
        (result,) = run_evaluation(make_policy("openpi", options), config, tmp_path / "run", show_progress=False)
        with pytest.raises(RoboLabError, match="run with --realtime"):  # one folder, one timing
            run_evaluation(
                make_policy("openpi", PolicyOptions(port=port)), config, tmp_path / "run", show_progress=False
            )
    finally:
        server.stop()
    assert result.error is None and result.steps == STEPS and result.realtime

    # the server saw one request per query, each with the step of its observation
    request_steps = [json.loads(line)["robolab/step"] for line in log.read_text().splitlines()]
    assert result.queries == len(request_steps) >= 3
    assert request_steps[0] == 0

    # latency: at least the server's delay; each reply arrived ceil(latency * 15) steps after its observation
    assert result.inference_ms_mean >= DELAY * 1000.0
    assert result.inference_ms_max >= result.inference_ms_mean
    delays = np.diff(request_steps)
    assert delays.min() >= math.ceil(DELAY * CONTROL_HZ)
    assert delays.max() <= math.ceil(result.inference_ms_max / 1000.0 * CONTROL_HZ)

    # every executed action is the one meant for its step (stale ones skipped), or a hold of the last target
    actions = np.load(actions_file(tmp_path / "run", "openpi", "BananaInBowl", "default", "droid", SEED))
    assert actions.shape == (STEPS, 8)
    aligned = {s for s in range(STEPS) if abs(actions[s, 6] - timed_target(s)) < 1e-5}
    held = set(range(STEPS)) - aligned
    assert result.held_steps == len(held)
    assert held == _expected_held(request_steps, STEPS)
    assert set(range(request_steps[1])) <= held  # nothing to do before the first reply
    for step in sorted(held - {0}):
        assert np.array_equal(actions[step], actions[step - 1]), step  # held: the last target again
    assert abs(actions[0, 6] - timed_target(0)) > 0.1  # the first holds keep the arm where it stands


def test_a_fast_server_is_asked_every_open_loop_horizon_and_only_the_first_reply_is_waited_for(tmp_path):
    port = free_port()
    log = tmp_path / "requests.jsonl"
    server = fault_server("openpi", port, {SEED: "timed"}, log)
    horizon, steps = 8, 24
    config = EvalConfig(tasks=("BananaInBowl",), episodes=1, first_seed=SEED, max_steps=steps, save_actions=True)
    try:
        (result,) = run_evaluation(
            make_policy("openpi", PolicyOptions(port=port, open_loop_horizon=horizon, realtime=True)),
            config,
            tmp_path,
            show_progress=False,
        )
    finally:
        server.stop()
    assert result.error is None and result.steps == steps
    longest = math.ceil(result.inference_ms_max / 1000.0 * CONTROL_HZ)  # steps the slowest reply took
    if longest > horizon:
        pytest.skip(f"this machine answered a local query in {result.inference_ms_max} ms; the test needs < 533 ms")
    request_steps = [json.loads(line)["robolab/step"] for line in log.read_text().splitlines()]
    assert request_steps == list(range(0, steps, horizon))  # every 8 steps: each reply came within them
    actions = np.load(actions_file(tmp_path, "openpi", "BananaInBowl", "default", "droid", SEED))
    aligned = [abs(actions[s, 6] - timed_target(s)) < 1e-5 for s in range(steps)]
    assert 1 <= result.held_steps <= longest  # the arm waited for the first reply only
    assert aligned == [False] * result.held_steps + [True] * (steps - result.held_steps)


def test_realtime_is_refused_for_policies_that_run_in_process():
    result = subprocess.run(
        [ROBOLAB, "eval", "--policy", "random", "--realtime", "--task", "BananaInBowl"],
        check=False,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "--realtime: policy 'random' computes in this process" in result.stderr
    assert "robolab serve --policy random" in result.stderr  # the way to do it
    with pytest.raises(RoboLabError, match="the oracle reads the simulator and cannot be served"):
        make_policy("oracle", PolicyOptions(realtime=True))


def test_a_served_policy_with_a_delay_answers_no_sooner():
    session = PolicySession(HoldPolicy(), action_horizon=4, delay=0.3)
    observation = {"joint_position": np.zeros((1, 7), np.float32), "prompt": "put the banana in the bowl"}
    episode = {"seed": 0, "step": 0, "action_low": -np.ones(8, np.float32), "action_high": np.ones(8, np.float32)}
    start = time.perf_counter()
    chunk = session.answer(observation, episode)
    assert time.perf_counter() - start >= 0.3
    assert chunk.shape == (4, 8) and not chunk.any()  # the hold policy's answer, unchanged
