"""What the determinism contract costs: reset() with a new PhysX scene per episode against the old reset that reused
the scene (reconfiguration_freq=0), and an exact set_state_dict against ManiSkill's plain one, in one process.

    .venv/bin/python benchmarks/reset_cost.py [--task BananaInBowl] [--obs-mode state_dict] [--resets 8]

Prints the mean time of each and the ratios. The new reset is a full scene rebuild, so its cost grows with the scene
and the cameras; the exact restore replays the episode, so its cost grows with the step it restores.
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import mani_skill.envs  # noqa: F401  (registers the RoboLab environments)
import numpy as np


def mean_reset_seconds(env, resets: int, rounds: int = 3) -> float:
    samples = []
    for round_index in range(rounds):
        start = time.perf_counter()
        for seed in range(resets):
            env.reset(seed=round_index * resets + seed)
        samples.append((time.perf_counter() - start) / resets)
    return statistics.median(samples)


def restore_seconds(env, steps: int, exact: bool) -> float:
    base = env.unwrapped
    space = base.single_action_space
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    for _ in range(steps):
        env.step(rng.uniform(space.low, space.high).astype(np.float32))
    state = base.get_state_dict()
    env.step(rng.uniform(space.low, space.high).astype(np.float32))
    if not exact:
        state = {key: value for key, value in state.items() if key != "episode"}
    start = time.perf_counter()
    base.set_state_dict(state)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="BananaInBowl")
    parser.add_argument("--obs-mode", default="state_dict", help="state_dict (no cameras) or rgb (two cameras)")
    parser.add_argument("--resets", type=int, default=8)
    parser.add_argument("--restore-steps", type=int, default=100, help="the step of the state that is restored")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.resets, args.restore_steps = 1, 2

    kwargs = dict(obs_mode=args.obs_mode, render_backend="cpu")
    reused = gym.make(f"RoboLab-{args.task}-v1", reconfiguration_freq=0, **kwargs)  # the reset before the contract
    rebuilt = gym.make(f"RoboLab-{args.task}-v1", **kwargs)
    reused.reset(seed=0)
    rebuilt.reset(seed=0)
    old = new = 0.0
    for _ in range(2):  # alternate, so drifting machine load hits both alike
        old = mean_reset_seconds(reused, args.resets)
        new = mean_reset_seconds(rebuilt, args.resets)
    print(
        f"reset ({args.task}, {args.obs_mode}): reused scene {old * 1000:.1f} ms, new scene {new * 1000:.1f} ms, "
        f"ratio {new / old:.1f}x (+{(new - old) * 1000:.0f} ms per episode)"
    )

    plain = restore_seconds(rebuilt, args.restore_steps, exact=False)
    exact = restore_seconds(rebuilt, args.restore_steps, exact=True)
    print(
        f"set_state_dict at step {args.restore_steps}: ManiSkill's {plain * 1000:.1f} ms, exact (rebuild + replay) "
        f"{exact * 1000:.0f} ms, ratio {exact / plain:.0f}x"
    )
    reused.close()
    rebuilt.close()


if __name__ == "__main__":
    main()
