"""The `robolab generate scene` command: its options and what it runs (heavy modules are imported when it runs)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from robolab_ms.generation.llm import add_endpoint_arguments, chat_client_from_args


def add_scene_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("prompt", metavar="PROMPT", help='what the scene should show, e.g. "a red mug left of a white '
                        'bowl, a banana in the bowl"')  # fmt: skip
    parser.add_argument("--out", required=True, metavar="FILE.yaml", help="the scene file to write; its name is the "
                        "scene's name; the preview FILE.png and the transcript FILE.transcript.json go next to it")  # fmt: skip
    parser.add_argument("--objects", nargs="+", metavar="NAME", help="catalog objects the scene must contain")
    parser.add_argument("--method", choices=("solver", "grid"), default="solver",
                        help="solver: relations, solvers, physics and feedback rounds (default); grid: RoboLab's "
                        "single-pass baseline (objects on an R x C grid, quarter-cell jitter, no stacking)")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=4, help="at most this many answers of the model (default 4)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the solver's random choices (default 0)")
    parser.add_argument("--no-preview", action="store_true", help="skip the rendered preview image")
    add_endpoint_arguments(parser)


def run_scene(args: argparse.Namespace) -> int:
    from robolab_ms.catalog import load_catalog
    from robolab_ms.errors import RoboLabError
    from robolab_ms.generation.offline import OfflineSceneModel
    from robolab_ms.generation.scene import generate_scene

    if args.rounds < 1:
        raise RoboLabError(f"--rounds {args.rounds}: give at least 1")
    catalog = load_catalog()
    model = OfflineSceneModel(catalog) if args.llm == "offline" else chat_client_from_args(args)
    result = generate_scene(args.prompt, Path(args.out), model, method=args.method, objects=args.objects,
                            rounds=args.rounds, seed=args.seed, render=not args.no_preview, catalog=catalog)  # fmt: skip
    settled = result.settled
    if settled is not None:
        held = f", {result.satisfied()} of {len(result.requested)} requested relations hold" if result.requested else ""
        worst = max(settled.drift.values(), default=0.0)
        print(f"{len(result.objects)} objects, largest drift {worst * 100:.1f} cm over 300 physics steps{held}; "
              f"{result.rounds} round(s), {result.seconds:.1f} s")  # fmt: skip
    for line in result.relaxed:
        print(f"relaxed: {line}")
    if not result.accepted:
        print(f"robolab: error: no scene after {result.rounds} round(s): " + "; ".join(result.problems),
              file=sys.stderr)  # fmt: skip
        print(f"transcript: {result.transcript}", file=sys.stderr)
        return 1
    print(f"scene: {result.scene_file}")
    if result.preview:
        print(f"preview: {result.preview}")
    print(f"transcript: {result.transcript}")
    return 0
