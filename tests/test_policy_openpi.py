"""The openpi client and `robolab serve`, against real server processes on 127.0.0.1."""

from __future__ import annotations

import subprocess
import threading

import numpy as np
import pytest
from servers import ROBOLAB, free_port, robolab_serve

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import PolicyOptions, make_policy


@pytest.fixture(scope="module")
def random_server():
    port = free_port()
    server = robolab_serve("--policy", "random", "--port", str(port), "--host", "127.0.0.1")
    yield port
    server.stop()


def test_no_server_is_one_paragraph_naming_the_address_and_exit_2(tmp_path):
    port = free_port()  # nothing listens there
    out = tmp_path / "run"
    result = subprocess.run(
        [*ROBOLAB, "eval", "--policy", "openpi", "--port", str(port), "--task", "BananaInBowl", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 2, result.stderr
    message = result.stderr.strip()
    assert "Traceback" not in message and "\n" not in message  # one paragraph
    assert f"127.0.0.1:{port}" in message and "robolab serve" in message
    assert not (out / "episodes.jsonl").exists()  # before any episode


def _client_request(seed: int, step: int) -> dict:
    image = np.zeros((224, 224, 3), np.uint8)
    return {
        "observation/exterior_image_1_left": image,
        "observation/wrist_image_left": image,
        "observation/joint_position": np.zeros(7, np.float32),
        "observation/gripper_position": np.zeros(1, np.float32),
        "prompt": "put the banana in the bowl",
        "robolab/task": "BananaInBowl",
        "robolab/seed": seed,
        "robolab/step": step,
    }


@pytest.mark.filterwarnings("ignore:connect\\(\\) must be used as a context manager:DeprecationWarning")
def test_serve_sends_metadata_and_answers_several_clients_at_once(random_server):
    from openpi_client.websocket_client_policy import WebsocketClientPolicy

    clients = [WebsocketClientPolicy(host="127.0.0.1", port=random_server) for _ in range(3)]
    for client in clients:
        metadata = client.get_server_metadata()
        assert metadata["server"] == "robolab_ms" and metadata["policy"] == "random"
        assert metadata["action_horizon"] == 10
    replies: dict[int, list] = {}

    def ask(index: int) -> None:  # all three at once, each on its own connection
        replies[index] = [clients[index].infer(_client_request(index % 2, step))["actions"] for step in (0, 8, 16)]

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert sorted(replies) == [0, 1, 2]
    for chunks in replies.values():
        assert all(chunk.shape == (10, 8) and chunk.dtype == np.float32 for chunk in chunks)
    # each client has its own policy, seeded from the episode seed: seed 0 twice gives the same actions
    np.testing.assert_array_equal(replies[0][0], replies[2][0])
    assert not np.array_equal(replies[0][0], replies[1][0])
    assert not np.array_equal(replies[0][0], replies[0][1])  # the next request of an episode goes on


def test_eval_through_serve_records_endpoint_metadata_and_timing(tmp_path):
    port = free_port()
    server = robolab_serve("--policy", "hold", "--port", str(port), "--host", "127.0.0.1")
    try:
        policy = make_policy("openpi", PolicyOptions(port=port, open_loop_horizon=8))
        config = EvalConfig(tasks=("BananaInBowl",), episodes=2, max_steps=12)
        results = run_evaluation(policy, config, tmp_path, show_progress=False)
    finally:
        server.stop()
    assert [r.seed for r in results] == [0, 1]
    for result in results:
        assert result.error is None and result.steps == 12
        assert result.endpoint == f"ws://127.0.0.1:{port}"
        assert result.policy_metadata["server"] == "robolab_ms" and result.policy_metadata["policy"] == "hold"
        assert result.queries == 2  # 8 actions of the first chunk, then 4 of the second
        assert result.inference_ms_p95 >= result.inference_ms_mean > 0
        assert result.env_step_ms > 0 and result.steps_per_second > 0
        assert result.clipped_steps == 0
