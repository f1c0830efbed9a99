"""The GR00T client (ZMQ + msgpack) against real server processes: `robolab serve --protocol gr00t` and a faulty one."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from servers import fault_server, free_port, robolab_serve

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import PolicyOptions, PolicyUnavailableError, make_policy
from robolab_ms.policies.gr00t import eef_9d

FAULTS = {0: "shape", 1: "nan", 3: "missing", 4: "late", 5: "error", 6: "dtype"}
EXPECTED = {
    0: "expected (1, H, 7)",
    1: "NaN",
    3: "no 'action.gripper_position'",
    4: "did not answer within 1 s",
    5: "failed on purpose",
    6: "dtype int64",
}


def test_eef_9d_is_position_and_droid_6d_rotation():
    identity = eef_9d(np.array([[0.4, 0.1, 0.3, 1.0, 0.0, 0.0, 0.0]]))
    np.testing.assert_allclose(identity, [[0.4, 0.1, 0.3, 0, 0, -1, -1, 0, 0]], atol=1e-6)
    half = math.sqrt(0.5)  # 90 degrees about z: x -> y
    turned = eef_9d(np.array([[0.0, 0.0, 0.0, half, 0.0, 0.0, half]]))
    np.testing.assert_allclose(turned[0, 3:], [1, 0, 0, 0, 0, -1], atol=1e-6)


def test_no_gr00t_server_names_the_address():
    port = free_port()
    with pytest.raises(PolicyUnavailableError, match=f"127.0.0.1:{port}.*robolab serve --protocol gr00t"):
        make_policy("gr00t", PolicyOptions(port=port)).connect()


def test_gr00t_through_serve(tmp_path):
    port = free_port()
    server = robolab_serve("--protocol", "gr00t", "--policy", "hold", "--port", str(port), "--host", "127.0.0.1")
    try:
        results = run_evaluation(
            make_policy("gr00t", PolicyOptions(port=port)),
            EvalConfig(tasks=("BananaInBowl",), episodes=1, max_steps=10),
            tmp_path,
            show_progress=False,
        )
    finally:
        server.stop()
    (result,) = results
    assert result.error is None and result.steps == 10 and result.queries == 2
    assert result.endpoint == f"tcp://127.0.0.1:{port}"
    assert result.policy_metadata["server"] == "robolab_ms" and result.policy_metadata["protocol"] == "gr00t"
    assert result.policy_metadata["request_format"] == "n1.6"


def test_gr00t_request_format_and_faults(tmp_path):
    port, log = free_port(), tmp_path / "requests.jsonl"
    server = fault_server("gr00t", port, FAULTS, log)
    try:
        results = run_evaluation(
            make_policy("gr00t", PolicyOptions(port=port, timeout=1.0, gr00t_version="n1.5")),
            EvalConfig(tasks=("BananaInBowl",), episodes=8, max_steps=3),
            tmp_path,
            show_progress=False,
        )
    finally:
        server.stop()
    by_seed = {r.seed: r for r in results}
    for seed, text in EXPECTED.items():
        assert by_seed[seed].error is not None and text in by_seed[seed].error, (seed, by_seed[seed].error)
    assert by_seed[2].error is None and by_seed[7].error is None and by_seed[7].steps == 3  # also after a late one

    request = json.loads(log.read_text().splitlines()[0])
    assert request["video.exterior_image_1_left"] == [[1, 1, 180, 320, 3], "uint8"]
    assert request["video.wrist_image_left"] == [[1, 1, 180, 320, 3], "uint8"]
    assert request["state.joint_position"] == [[1, 1, 7], "float32"]
    assert request["state.gripper_position"] == [[1, 1, 1], "float32"]
    assert request["state.eef_9d"] == [[1, 1, 9], "float32"]
    assert request["annotation.language.language_instruction"] == "list"
    assert request["robolab.seed"] == 0 and request["robolab.task"] == "BananaInBowl"
