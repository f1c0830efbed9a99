"""In-process LeRobot-style policies: `--policy module.path:factory`."""

from __future__ import annotations

import lerobot_style_policies
import pytest
import torch

from robolab_ms.errors import RoboLabError
from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy


def test_lerobot_policy_gets_lerobot_batches_and_is_seeded_per_episode(tmp_path):
    policy = make_policy("lerobot_style_policies:make")
    config = EvalConfig(tasks=("BananaInBowl",), episodes=2, max_steps=4)
    results = run_evaluation(policy, config, tmp_path, show_progress=False)
    assert [(r.error, r.steps, r.policy, r.queries) for r in results] == [
        (None, 4, "lerobot_style_policies:make", 4)
    ] * 2
    model = lerobot_style_policies.MADE[-1]
    assert model.resets == 2 and len(model.batches) == 8
    batch = model.batches[0]
    assert set(batch) == {
        "observation.images.exterior_1_left",
        "observation.images.wrist_left",
        "observation.state",
        "task",
    }
    for camera in ("observation.images.exterior_1_left", "observation.images.wrist_left"):
        image = batch[camera]
        assert image.shape == (1, 3, 180, 320) and image.dtype == torch.float32
        assert 0.0 <= float(image.min()) and float(image.max()) <= 1.0 and float(image.max()) > 0.1
    assert batch["observation.state"].shape == (1, 8) and batch["observation.state"].dtype == torch.float32
    assert batch["task"] == [results[0].instruction]
    expected = []
    for seed in (0, 1):  # torch's generator is seeded from the episode seed before reset()
        torch.manual_seed(seed)
        expected.append(float(torch.rand(1)))
    assert model.draws == expected


def test_bad_lerobot_policies_are_clear(tmp_path):
    with pytest.raises(RoboLabError, match="cannot import module 'no_such_module'"):
        make_policy("no_such_module:make")
    with pytest.raises(RoboLabError, match="without reset and select_action"):
        make_policy("lerobot_style_policies:not_a_policy")
    with pytest.raises(RoboLabError, match="no callable 'missing'"):
        make_policy("lerobot_style_policies:missing")
    results = run_evaluation(
        make_policy("lerobot_style_policies:wrong_shape"),
        EvalConfig(tasks=("BananaInBowl",), episodes=1, max_steps=2),
        tmp_path,
        show_progress=False,
    )
    assert "shape (1, 6)" in results[0].error and results[0].steps == 0
