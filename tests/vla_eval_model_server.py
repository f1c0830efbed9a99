"""A vla-eval model server for the tests: one of our policies (random, replay, ...) behind vla-eval's
PredictModelServer, one action per observation.

    python tests/vla_eval_model_server.py --policy replay --replay-from DIR [--no-images] [--log FILE] [--port N]

It prints `vla-eval model server: ws://127.0.0.1:PORT` once it listens (--port 0, the default, takes a free port).
The observation is our openpi request (RoboLabBenchmark), turned back into a DROID observation the way
`robolab serve` does; the policy is reset from the task dict vla-eval sends at the episode start (task, variant,
robot, seed, action bounds). --no-images asks the benchmark for no images (vla-eval's observation params). --log FILE
gets one JSON line per episode: the task dict and, for the first observation, every key's shape and dtype.
"""

from __future__ import annotations

import argparse
import functools
import json
import logging
from pathlib import Path
from typing import Any

import anyio
import numpy as np
from vla_eval.model_servers.base import SessionContext
from vla_eval.model_servers.predict import PredictModelServer
from vla_eval.model_servers.serve import serve_async
from vla_eval.specs import DimSpec
from vla_eval.types import Action, Observation

from robolab_ms.eval.vla_eval_benchmark import ACTION_FORMAT
from robolab_ms.policies import PolicyOptions, make_policy
from robolab_ms.policies.server import PolicySession, _openpi_observation


class PolicyModelServer(PredictModelServer):
    """Serves one of our policies to vla-eval: one action per observation."""

    def __init__(
        self, policy: str, replay_from: str | None = None, images: bool = True, log: str | None = None
    ) -> None:
        super().__init__()
        self.policy = make_policy(policy, PolicyOptions(replay_from=Path(replay_from) if replay_from else None))
        self.images, self.log = images, Path(log) if log else None
        self.session = PolicySession(self.policy, action_horizon=1)
        self.episode: dict[str, Any] = {}

    def get_observation_params(self) -> dict[str, Any]:
        return {"images": self.images}

    def get_action_spec(self) -> dict[str, DimSpec]:
        return {"actions": DimSpec("actions", 8, ACTION_FORMAT)}

    def get_observation_spec(self) -> dict[str, DimSpec]:
        return {"prompt": DimSpec("prompt", 0, "language")}

    async def on_episode_start(self, config: dict[str, Any], ctx: SessionContext) -> None:
        await super().on_episode_start(config, ctx)
        self.episode = dict(config.get("task") or {})

    def predict(self, obs: Observation, ctx: SessionContext) -> Action:
        observation, _ = _openpi_observation(obs)
        if ctx.step == 0 and self.log is not None:
            shapes = {key: [list(np.shape(value)), str(np.asarray(value).dtype)] for key, value in obs.items()}
            with self.log.open("a", encoding="utf-8") as handle:
                handle.write(json.dumps({"task": self.episode, "observation": shapes}) + "\n")
        chunk = self.session.answer(observation, {**self.episode, "step": ctx.step})
        return {"actions": chunk[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default="random")
    parser.add_argument("--replay-from", default=None)
    parser.add_argument("--no-images", action="store_true")
    parser.add_argument("--log", default=None)
    parser.add_argument("--port", type=int, default=0)
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    server = PolicyModelServer(args.policy, args.replay_from, images=not args.no_images, log=args.log)

    async def run() -> None:
        async with anyio.create_task_group() as group:
            port = await group.start(functools.partial(serve_async, server, "127.0.0.1", args.port))
            print(f"vla-eval model server: ws://127.0.0.1:{port}", flush=True)

    anyio.run(run)


if __name__ == "__main__":
    main()
