"""What domain randomization costs at reset: reset() with every variation axis on against reset() with none, same
task, same process, with the policy cameras rendering (the first observation is part of a reset).

    .venv/bin/python benchmarks/variation_reset_cost.py [--task RubiksCubeBehindBowl] [--seeds 12]

Both environments rebuild their scene at every reset (the determinism contract), so the variations add no rebuild:
lights, background, table, distractor looks and camera mounts are chosen while the scene is built, object poses
and robot joints are set with the state. What they do add once per process is the first use of each environment map
(a background at a light level): SAPIEN filters it at its first render, seconds on a CPU renderer. The script runs
the seeds with every axis on once (cold: it pays those first uses), then alternates resets of both environments over
the same seeds (warm, the steady state of a long run). It prints the median reset time of each, the ratio warm / none
(target <= 1.5) and the one-time cost per new environment map.
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import mani_skill.envs  # noqa: F401  (registers the RoboLab environments)

EVERY_AXIS = "lighting,background,table,camera,objects,robot,noise,distractors"


def reset_seconds(env, seed: int) -> float:
    start = time.perf_counter()
    env.reset(seed=seed)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", default="RubiksCubeBehindBowl")
    parser.add_argument("--seeds", type=int, default=12)
    parser.add_argument("--rounds", type=int, default=3, help="warm passes over the seeds")
    parser.add_argument("--vary", default=EVERY_AXIS)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.rounds = 1, 1

    kwargs = dict(obs_mode="rgb", render_backend="cpu")
    plain = gym.make(f"RoboLab-{args.task}-v1", **kwargs)
    varied = gym.make(f"RoboLab-{args.task}-v1", variations=args.vary, **kwargs)
    plain.reset(seed=1000)
    seeds = range(args.seeds)
    maps_before = _environment_maps()
    cold = [reset_seconds(varied, seed) for seed in seeds]
    new_maps = _environment_maps() - maps_before
    none, warm = [], []
    for _ in range(args.rounds):  # alternate reset by reset, so drifting machine load hits both alike
        for seed in seeds:
            none.append(reset_seconds(plain, seed))
            warm.append(reset_seconds(varied, seed))
    none_median, warm_median = statistics.median(none), statistics.median(warm)
    print(
        f"reset ({args.task}, rgb, {args.seeds} seeds x {args.rounds} rounds, medians): no variations "
        f"{none_median * 1000:.0f} ms; every axis ({args.vary}) warm {warm_median * 1000:.0f} ms, ratio "
        f"{warm_median / none_median:.2f}x (target <= 1.5)"
    )
    per_map = (sum(cold) - len(cold) * warm_median) / max(new_maps, 1)
    print(
        f"first pass (cold): {statistics.mean(cold) * 1000:.0f} ms per reset; {new_maps} environment maps made for "
        f"the first time, about {per_map:.1f} s each (once per background and light level per process)"
    )
    plain.close()
    varied.close()


def _environment_maps() -> int:
    """How many environment maps this process has loaded (each is filtered at its first render)."""
    from robolab_ms.scene.backgrounds import lighting_cubemap

    return lighting_cubemap.cache_info().currsize


if __name__ == "__main__":
    main()
