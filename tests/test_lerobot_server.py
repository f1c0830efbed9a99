"""LeRobot policies in their own Python 3.12 environment, served by robolab_ms/policies/lerobot_server.py and
evaluated with `robolab eval --policy openpi`: real LeRobot policy classes (ACT from a checkpoint folder, Diffusion
Policy from its config class), random weights, nothing downloaded, real BananaInBowl episodes.

The environment is built (or reused) by scripts/setup_lerobot_env.sh; the first build downloads about 3 GB and
takes minutes. Skipped only where no Python 3.12 is installed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from servers import ROBOLAB, ServerProcess

from robolab_ms.agents.droid_model import ARM_LOWER, ARM_UPPER

# a second Python environment (built once, about 4 minutes) and LeRobot policies served: `make test-slow`
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
SETUP = ROOT / "scripts" / "setup_lerobot_env.sh"
READY = "lerobot_server: serving"
CAMERAS = ("observation.images.exterior_1_left", "observation.images.wrist_left")
MAX_STEPS, OPEN_LOOP = 16, 8

# Where the policies' actions are put by their normalization statistics: mid-range joint targets, gripper at 0.2.
ACTION_MEAN = [*((np.array(ARM_LOWER) + np.array(ARM_UPPER)) / 2).round(3).tolist(), 0.2]
ACTION_STD = [0.01] * 8
STATS = {
    "action": {"mean": ACTION_MEAN, "std": ACTION_STD,
               "min": [value - 0.05 for value in ACTION_MEAN], "max": [value + 0.05 for value in ACTION_MEAN]},
    "observation.state": {"mean": [0.0] * 8, "std": [1.0] * 8, "min": [-3.0] * 7 + [0.0], "max": [3.0] * 7 + [1.0]},
}  # fmt: skip


@pytest.fixture(scope="module")
def lerobot_python() -> str:
    found = subprocess.run([str(SETUP), "--find-python"], capture_output=True, text=True)
    if found.returncode == 3:
        pytest.skip(f"LeRobot's environment needs Python 3.12: {found.stderr.strip()}")
    built = subprocess.run([str(SETUP)], capture_output=True, text=True, timeout=3600)
    assert built.returncode == 0, f"scripts/setup_lerobot_env.sh failed:\n{built.stderr[-4000:]}"
    return built.stdout.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def stats_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("lerobot") / "stats.json"
    path.write_text(json.dumps(STATS))
    return path


WITH_CHECKOUT = {**os.environ, "PYTHONPATH": str(ROOT)}
# the two ways to start it: as a module with this checkout on PYTHONPATH, or as a script file that finds its checkout
SERVER_MODULE = (["-m", "robolab_ms.policies.lerobot_server"], WITH_CHECKOUT)
SERVER_SCRIPT = (
    [str(ROOT / "robolab_ms" / "policies" / "lerobot_server.py")],
    {key: value for key, value in os.environ.items() if key != "PYTHONPATH"},
)


def _serve(python: str, how: tuple[list[str], dict], tmp: Path, *options: str) -> tuple[ServerProcess, int]:
    start, env = how
    server = ServerProcess(
        [
            python,
            *start,
            "--host",
            "127.0.0.1",
            "--port",
            "0",
            "--device",
            "cpu",
            "--log-inputs",
            str(tmp / "inputs.json"),
            "--log-actions",
            str(tmp / "replies.jsonl"),
            *options,
        ],
        ready=READY,
        timeout=300,
        env=env,
    )
    port = int(server.lines[-1].split("ws://127.0.0.1:")[1].split(",")[0])
    return server, port


def _evaluate(port: int, out: Path, episodes: int) -> list[dict]:
    run = subprocess.run(
        [
            *ROBOLAB,
            "eval",
            "--policy",
            "openpi",
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
            "--task",
            "BananaInBowl",
            "--episodes",
            str(episodes),
            "--max-steps",
            str(MAX_STEPS),
            "--open-loop-horizon",
            str(OPEN_LOOP),
            "--save-actions",
            "--quiet",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr[-4000:]
    return [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]


def _check_inputs(tmp: Path, image_shape: list[int], instruction: str) -> None:
    """What LeRobot's pre-processor received: the raw batch of LeRobot's evaluation loop."""
    logged = json.loads((tmp / "inputs.json").read_text())
    batch = logged["batch"]
    assert set(batch) == {*CAMERAS, "observation.state", "task"}
    for camera in CAMERAS:
        image = batch[camera]
        assert image["shape"] == [1, *image_shape] and image["dtype"] == "float32"
        assert 0.0 <= image["min"] and image["max"] <= 1.0 and image["max"] > 0.2  # scaled to [0, 1], not black
    state = batch["observation.state"]
    assert state["shape"] == [1, 8] and state["dtype"] == "float32"
    assert min(ARM_LOWER) <= state["min"] and state["max"] <= max(ARM_UPPER) and state["min"] < state["max"]
    assert batch["task"] == [instruction]
    assert logged["inputs"] == {
        CAMERAS[0]: "exterior_image_1_left",
        CAMERAS[1]: "wrist_image_left",
        "observation.state": "joint_position+gripper_position",
    }


def _check_executed(tmp: Path, out: Path, results: list[dict], policy: str, chunk: int) -> None:
    """Each episode ran its steps with the actions the server sent: the post-processed policy output, in order."""
    replies = [json.loads(line) for line in (tmp / "replies.jsonl").read_text().splitlines()]
    assert len(results) == len({row["seed"] for row in results}) >= 2
    for row in results:
        assert row["policy_metadata"]["policy"] == policy and row["policy_metadata"]["server"] == "robolab_ms"
        assert not row.get("error") and row["steps"] == MAX_STEPS
        assert row["queries"] == MAX_STEPS // OPEN_LOOP
        sent = [reply for reply in replies if reply["seed"] == row["seed"]]
        assert [reply["step"] for reply in sent] == list(range(0, MAX_STEPS, OPEN_LOOP))
        for reply in sent:
            raw, actions = np.array(reply["policy_actions"]), np.array(reply["actions"], np.float32)
            assert raw.shape == (chunk, 8) and actions.shape == (chunk, 8)
            np.testing.assert_array_equal(actions, raw.astype(np.float32))  # 8-D policy: mapped one to one
            # un-normalized by the post-processor with the statistics: around their mean, far from N(0, 1)
            assert np.all(np.abs(raw - np.array(ACTION_MEAN)) < 0.1)
        saved = np.load(
            out
            / "actions"
            / "openpi"
            / "BananaInBowl"
            / f"{row['instruction_variant']}-{row['robot']}-seed{row['seed']}.npy"
        )
        expected = np.concatenate([np.array(reply["actions"], np.float32)[:OPEN_LOOP] for reply in sent])
        np.testing.assert_allclose(saved, expected, atol=1e-6)


ACT_CHECKPOINT = ["--policy-type", "act", "--image-size", "180,320", "--set", "pretrained_backbone_weights=null",
                  "--set", "chunk_size=20", "--set", "n_action_steps=20", "--set", "dim_model=128",
                  "--set", "dim_feedforward=512"]  # fmt: skip
DIFFUSION = [
    "--policy-type",
    "diffusion",
    "--image-size",
    "96,96",
    "--set",
    "num_inference_steps=2",
    "--set",
    "down_dims=[64,128]",
    "--set",
    "horizon=16",
    "--set",
    "n_action_steps=8",
]


def _act_from_checkpoint(python: str, tmp: Path, stats: Path) -> list[dict]:
    """ACT saved as LeRobot saves a trained policy, served with --checkpoint (as a module), evaluated."""
    checkpoint = tmp / "act_checkpoint"
    made = subprocess.run(
        [
            python,
            str(ROOT / "tests" / "lerobot_checkpoint.py"),
            *ACT_CHECKPOINT,
            "--out",
            str(checkpoint),
            "--stats",
            str(stats),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert made.returncode == 0, made.stderr[-4000:]
    server, port = _serve(python, SERVER_MODULE, tmp, "--checkpoint", str(checkpoint))
    try:
        return _evaluate(port, tmp / "run", episodes=2)
    finally:
        server.stop()


def _diffusion_from_config(python: str, tmp: Path, stats: Path) -> list[dict]:
    """Diffusion Policy built from its config class by the server (as a script file), evaluated."""
    server, port = _serve(python, SERVER_SCRIPT, tmp, *DIFFUSION, "--stats", str(stats))
    try:
        return _evaluate(port, tmp / "run", episodes=2)
    finally:
        server.stop()


@pytest.fixture(scope="module")
def runs(lerobot_python, stats_file, tmp_path_factory) -> dict[str, tuple[Path, list[dict]]]:
    """Both policies served and evaluated side by side (each is mostly start-up: imports, env build)."""
    folders = {name: tmp_path_factory.mktemp(name) for name in ("act", "diffusion")}
    with ThreadPoolExecutor(2) as pool:
        act = pool.submit(_act_from_checkpoint, lerobot_python, folders["act"], stats_file)
        diffusion = pool.submit(_diffusion_from_config, lerobot_python, folders["diffusion"], stats_file)
        return {"act": (folders["act"], act.result()), "diffusion": (folders["diffusion"], diffusion.result())}


def test_act_checkpoint_folder_served_and_evaluated(runs):
    tmp, results = runs["act"]
    # openpi's 224x224 padded images, the black border taken off and scaled back to the policy's 180x320
    _check_inputs(tmp, [3, 180, 320], results[0]["instruction"])
    _check_executed(tmp, tmp / "run", results, "lerobot-act", chunk=20)
    assert results[0]["policy_metadata"]["policy_source"] == str(tmp / "act_checkpoint")


def test_diffusion_policy_type_served_and_evaluated(runs):
    tmp, results = runs["diffusion"]
    _check_inputs(tmp, [3, 96, 96], results[0]["instruction"])
    _check_executed(tmp, tmp / "run", results, "lerobot-diffusion", chunk=8)
    assert results[0]["policy_metadata"]["policy_source"] == "random weights"


RESIZE = """
import sys
import numpy as np
from robolab_ms.policies.lerobot_server import image_to_feature

content = np.zeros((126, 224, 3), np.uint8)  # a 16:9 picture: red left half, blue right half
content[:, :112, 0] = 200
content[:, 112:, 2] = 200
padded = np.zeros((224, 224, 3), np.uint8)  # as openpi's clients send it: padded to a square
padded[49:175] = content
for shape in [(3, 180, 320), (3, 96, 96), (3, 224, 224)]:
    np.save(f"{sys.argv[1]}/{shape[1]}x{shape[2]}.npy", image_to_feature(padded, shape).numpy())
np.save(f"{sys.argv[1]}/padded.npy", padded)
"""


def test_padded_image_is_fitted_to_the_feature_keeping_its_aspect(lerobot_python, tmp_path):
    run = subprocess.run(
        [lerobot_python, "-c", RESIZE, str(tmp_path)], capture_output=True, text=True, timeout=300, env=WITH_CHECKOUT
    )
    assert run.returncode == 0, run.stderr[-4000:]
    wide = np.load(tmp_path / "180x320.npy")
    assert wide.shape == (1, 3, 180, 320) and wide.dtype == np.float32
    assert np.all(wide[0].max(axis=(0, 2)) > 0.7)  # the black border is gone: every row is picture
    np.testing.assert_allclose(wide[0, :, :, :150].mean(axis=(1, 2)), [200 / 255, 0, 0], atol=0.01)
    np.testing.assert_allclose(wide[0, :, :, 170:].mean(axis=(1, 2)), [0, 0, 200 / 255], atol=0.01)
    square = np.load(tmp_path / "96x96.npy")[0]  # 16:9 into a square: 54 rows of picture, padded above and below
    assert square.shape == (3, 96, 96)
    assert square[:, :21].max() == 0 and square[:, 75:].max() == 0 and np.all(square[:, 21:75].max(axis=(0, 2)) > 0.7)
    same = np.load(tmp_path / "224x224.npy")[0]  # the feature's own size: passed as it is
    np.testing.assert_array_equal(same, np.load(tmp_path / "padded.npy").transpose(2, 0, 1) / np.float32(255))


def test_bad_option_is_one_line_and_exit_2(lerobot_python, tmp_path):
    run = subprocess.run(
        [lerobot_python, *SERVER_MODULE[0], "--checkpoint", str(tmp_path / "missing")],
        capture_output=True,
        text=True,
        timeout=300,
        env=WITH_CHECKOUT,
    )
    assert run.returncode == 2
    assert "Traceback" not in run.stderr and "no config.json there" in run.stderr


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-x", "-q"]))
