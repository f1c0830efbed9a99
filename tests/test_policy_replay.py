"""Replay check: the oracle's actions, recorded in process, replayed through `robolab serve` and the openpi client,
give the same success, score and step count seed by seed."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from servers import free_port, robolab_serve

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import PolicyOptions, make_policy
from robolab_ms.policies.replay import actions_file

# Five tasks, cut at 64 steps: the oracle is mid-task there (a grasp, a lift, an object on its way), and replays
# must reproduce its partial scores exactly.
TASKS = ("PickUpGreenObject", "PickGlasses", "MouseOnKeyboard", "BananaInBowl", "RubiksCubeLeftOfBowl")
CONFIG = EvalConfig(tasks=TASKS, episodes=1, first_seed=1, max_steps=64)


def _outcomes(results) -> dict:
    return {(r.task, r.seed): (r.success, r.score, r.progress, r.steps, r.success_step, r.error) for r in results}


@pytest.mark.slow
def test_oracle_actions_replayed_through_serve_and_openpi_reproduce_the_episodes(tmp_path):
    recording = replace(CONFIG, save_actions=True)  # what `robolab eval --save-actions` sets
    recorded = run_evaluation(make_policy("oracle"), recording, tmp_path / "oracle", show_progress=False)
    assert all(r.error is None for r in recorded)
    assert sum(r.score > 0 for r in recorded) >= 2  # the episodes did something worth reproducing
    actions = np.load(actions_file(tmp_path / "oracle", "oracle", "PickGlasses", "default", "droid", 1))
    assert actions.dtype == np.float32 and actions.shape == (recorded[1].steps, 8)

    in_process = run_evaluation(
        make_policy("replay", PolicyOptions(replay_from=tmp_path / "oracle")),
        CONFIG,
        tmp_path / "in_process",
        show_progress=False,
    )
    assert _outcomes(in_process) == _outcomes(recorded)

    port = free_port()
    server = robolab_serve(
        "--policy", "replay", "--replay-from", str(tmp_path / "oracle"), "--port", str(port), "--host", "127.0.0.1"
    )
    try:
        remote = run_evaluation(
            make_policy("openpi", PolicyOptions(port=port)), CONFIG, tmp_path / "remote", show_progress=False
        )
    finally:
        server.stop()
    assert all(r.policy_metadata.get("policy") == "replay" for r in remote)
    assert _outcomes(remote) == _outcomes(recorded)


def test_replay_names_what_is_missing(tmp_path):
    with pytest.raises(RoboLabError, match="save-actions"):
        make_policy("replay", PolicyOptions(replay_from=tmp_path))
    with pytest.raises(RoboLabError, match="--replay-from"):
        make_policy("replay")
