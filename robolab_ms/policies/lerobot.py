"""In-process policies in LeRobot's style: `--policy module.path:factory`.

`factory()` returns an object with `reset()` and `select_action(batch)`, as LeRobot's policies have. Each control
step it gets a batch with LeRobot's keys, torch tensors with a batch dimension of 1:

    observation.images.exterior_1_left, observation.images.wrist_left   float32 (1, 3, H, W) in [0, 1]
    observation.state   float32 (1, 8): 7 arm joint positions (rad) and the gripper position (0 open, 1 closed)
    task                [instruction]

and returns one action, (1, 8) or (8,): 7 absolute joint targets and the gripper (> 0.5 closes). A policy trained
with LeRobot on DROID-style data plugs in without a server. Before each episode torch's and numpy's global random
generators are seeded from the episode seed, then `reset()` is called.
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
from gymnasium import spaces

from robolab_ms.errors import RoboLabError
from robolab_ms.policies import Policy
from robolab_ms.policies.remote import check_chunk

CAMERA_KEYS = {
    "exterior_image_1_left": "observation.images.exterior_1_left",
    "wrist_image_left": "observation.images.wrist_left",
}


def droid_to_lerobot_batch(observation: dict[str, Any]) -> dict[str, Any]:
    """LeRobot's batch for one DROID observation (batched numpy arrays from DroidObservation)."""
    import torch

    batch: dict[str, Any] = {}
    for droid_key, lerobot_key in CAMERA_KEYS.items():
        image = torch.from_numpy(np.ascontiguousarray(observation[droid_key][:1]))
        batch[lerobot_key] = image.permute(0, 3, 1, 2).to(torch.float32) / 255.0
    state = np.concatenate([observation["joint_position"][:1], observation["gripper_position"][:1]], axis=1)
    batch["observation.state"] = torch.from_numpy(state.astype(np.float32))
    batch["task"] = [str(observation["prompt"])]
    return batch


class LeRobotPolicy(Policy):
    """Wraps an object with LeRobot's `reset()` / `select_action(batch)` interface."""

    needs_images = True

    def __init__(self, spec: str, model: Any) -> None:
        self.name = self.endpoint = spec
        self.model = model

    def metadata(self) -> dict[str, Any]:
        return {"class": f"{type(self.model).__module__}.{type(self.model).__qualname__}"}

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        import torch

        torch.manual_seed(seed)
        np.random.seed(seed % 2**32)
        self.model.reset()

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        import torch

        with torch.no_grad():
            action = self.model.select_action(droid_to_lerobot_batch(observation))
        if isinstance(action, torch.Tensor):
            action = action.detach().cpu().numpy()
        return check_chunk(np.asarray(action), f"{self.name}.select_action", key="action")[0]


def load_lerobot_policy(spec: str) -> LeRobotPolicy:
    """Import `module.path`, call `factory()` and check the result has `reset` and `select_action`."""
    module_name, _, attribute = spec.partition(":")
    if not module_name or not attribute:
        raise RoboLabError(f"--policy {spec!r}: an in-process policy is named 'module.path:factory'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise RoboLabError(
            f"--policy {spec!r}: cannot import module '{module_name}' ({exc}); install it or add "
            "its folder to PYTHONPATH"
        ) from None
    factory = getattr(module, attribute, None)
    if not callable(factory):
        raise RoboLabError(f"--policy {spec!r}: module '{module_name}' has no callable '{attribute}'")
    model = factory()
    missing = [name for name in ("reset", "select_action") if not callable(getattr(model, name, None))]
    if missing:
        raise RoboLabError(
            f"--policy {spec!r}: {attribute}() returned a {type(model).__name__} without "
            f"{' and '.join(missing)}(); a LeRobot-style policy has reset() and select_action(batch)"
        )
    return LeRobotPolicy(spec, model)
