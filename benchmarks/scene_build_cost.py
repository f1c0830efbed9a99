"""How long building a scene from the catalog takes, beyond renderer start-up.

Creates one ManiSkill environment (Panda arm, no cameras) that builds a scene file (so renderer start-up is paid once),
then rebuilds (reconfigures) it with:
  - baseline: banana_bowl, 5 procedural objects;
  - kitchen_table, 20 catalog objects (packaged meshes with textures and hull files, procedural shapes), the first
    time in this process (files parsed) and again (per-process caches warm).
Prints seconds and the ratio to the baseline. The catalog's target: the 20-object scene builds in under 1 s.

Run: python benchmarks/scene_build_cost.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import time

import mani_skill.envs  # noqa: F401  (ManiSkill's registry first)

from robolab_ms.scene import SceneSpec, load_scene
from robolab_ms.scene.scene_env import SceneOnlyEnv


def timed_rebuild(env: SceneOnlyEnv, scene: SceneSpec) -> float:
    env.scene_spec = scene
    start = time.perf_counter()
    env.reset(seed=0, options={"reconfigure": True})
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smallest settings: only checks that the script runs (its numbers mean nothing)",
    )
    args = parser.parse_args()
    if args.quick:
        args.repeats = 1
    baseline_scene, big_scene = load_scene("banana_bowl"), load_scene("kitchen_table")
    start = time.perf_counter()
    env = SceneOnlyEnv(baseline_scene)
    env.reset(seed=0)
    print(f"environment + renderer start-up (banana_bowl): {time.perf_counter() - start:.2f} s")
    baseline = min(timed_rebuild(env, baseline_scene) for _ in range(args.repeats))
    cold = timed_rebuild(env, big_scene)
    warm = min(timed_rebuild(env, big_scene) for _ in range(args.repeats))
    print(f"{'scene':34s} {'objects':>7s} {'seconds':>8s} {'ratio':>6s}")
    print(f"{'banana_bowl (baseline)':34s} {len(baseline_scene.objects):7d} {baseline:8.3f} {1.0:6.2f}")
    print(f"{'kitchen_table, first build':34s} {len(big_scene.objects):7d} {cold:8.3f} {cold / baseline:6.2f}")
    print(f"{'kitchen_table, caches warm':34s} {len(big_scene.objects):7d} {warm:8.3f} {warm / baseline:6.2f}")
    print(f"ratio 20-object scene (first build) / baseline: {cold / baseline:.2f}")
    print(f"target: 20-object scene under 1 s beyond renderer start-up -> {'met' if cold < 1.0 else 'NOT met'}")
    env.close()


if __name__ == "__main__":
    main()
