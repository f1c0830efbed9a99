"""Faults of a policy server: each episode they hit is recorded as errored with its reason, and the run goes on."""

from __future__ import annotations

import json
import threading
import time

import pytest
from servers import fault_server, free_port, robolab_serve

from robolab_ms.eval.results import EPISODES_FILE, read_results
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import PolicyOptions, make_policy

FAULTS = {0: "shape", 1: "nan", 3: "missing", 4: "dtype", 5: "inf", 6: "late", 7: "error", 8: "limits"}
EXPECTED = {
    0: "shape (10, 7)",
    1: "NaN",
    3: "no 'actions'",
    4: "dtype int64",
    5: "infinity",
    6: "did not answer within 1 s",
    7: "failed on purpose",
}


def _lines(folder) -> list[dict]:
    return [json.loads(line) for line in (folder / EPISODES_FILE).read_text().splitlines()]


@pytest.mark.slow
def test_bad_replies_error_their_episode_and_the_run_goes_on_then_retry_errors(tmp_path):
    port = free_port()
    server = fault_server("openpi", port, FAULTS, tmp_path / "requests.jsonl")
    config = EvalConfig(tasks=("BananaInBowl",), episodes=9, max_steps=3)
    options = PolicyOptions(port=port, timeout=1.0)
    try:
        results = run_evaluation(make_policy("openpi", options), config, tmp_path, show_progress=False)
        by_seed = {r.seed: r for r in results}
        assert sorted(by_seed) == list(range(9))
        for seed, text in EXPECTED.items():
            error = by_seed[seed].error
            assert error is not None and text in error, (seed, error)
            assert not by_seed[seed].success
        for seed in (2, 8):  # good replies, also after a late one (the client reconnected)
            assert by_seed[seed].error is None and by_seed[seed].steps == 3
        assert by_seed[8].clipped_steps == 3 and by_seed[2].clipped_steps == 0  # joint 1 at 5 rad, clipped

        # a plain rerun resumes: every episode has a line, nothing runs again
        run_evaluation(make_policy("openpi", options), config, tmp_path, show_progress=False)
        assert len(_lines(tmp_path)) == 9
    finally:
        server.stop()

    healed = fault_server("openpi", port, {}, tmp_path / "requests.jsonl")
    try:
        retried = EvalConfig(tasks=("BananaInBowl",), episodes=9, max_steps=3, retry_errors=True)
        results = run_evaluation(make_policy("openpi", options), retried, tmp_path, show_progress=False)
    finally:
        healed.stop()
    assert len(_lines(tmp_path)) == 9 + len(EXPECTED)  # only the errored episodes ran again
    assert all(r.error is None for r in results) and len(results) == 9
    assert all(r.error is None for r in read_results(tmp_path))  # the last line of an episode counts


@pytest.mark.slow
def test_server_killed_and_restarted_mid_run(tmp_path):
    port = free_port()
    serve_args = ("--policy", "hold", "--port", str(port), "--host", "127.0.0.1", "--log-requests")
    server = robolab_serve(*serve_args)
    config = EvalConfig(tasks=("BananaInBowl",), episodes=3, max_steps=24, reconnect_seconds=120.0)
    outcome: dict = {}

    def evaluate() -> None:
        try:
            outcome["results"] = run_evaluation(
                make_policy("openpi", PolicyOptions(port=port)), config, tmp_path, show_progress=False
            )
        except BaseException as exc:  # reported by the assertion below
            outcome["error"] = exc

    run = threading.Thread(target=evaluate)
    run.start()
    try:
        server.wait_for("seed 1 step 8:")  # the second episode's second query: mid-episode
        server.kill()
        server = robolab_serve(*serve_args)  # the run reconnects and goes on
        run.join(timeout=600)
    finally:
        server.stop()
    assert "error" not in outcome, outcome.get("error")
    lines = _lines(tmp_path)
    assert [line["seed"] for line in lines] == [0, 1, 2]
    assert lines[0]["error"] is None and lines[2]["error"] is None and lines[2]["steps"] == 24
    assert "PolicyConnectionLost" in lines[1]["error"] and f"127.0.0.1:{port}" in lines[1]["error"]


def test_a_server_that_stays_away_stops_the_run_after_bounded_backoff(tmp_path):
    from robolab_ms.eval.runner import _reconnect
    from robolab_ms.policies import PolicyUnavailableError

    policy = make_policy("openpi", PolicyOptions(port=free_port()))  # nothing listens there any more
    start = time.monotonic()
    with pytest.raises(PolicyUnavailableError, match=r"could not reconnect in 2 s \([3-9] tries.*--retry-errors"):
        _reconnect(policy, 2.0, tmp_path)
    assert time.monotonic() - start < 10
