"""The `robolab generate scene` command: its options and what it runs (heavy modules are imported when it runs)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from robolab_ms.generation.llm import add_endpoint_arguments, chat_client_from_args
from robolab_ms.physics import STABILITY_PHYSICS_STEPS


def add_scene_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "prompt",
        metavar="PROMPT",
        help='what the scene should show, e.g. "a red mug left of a white bowl, a banana in the bowl"',
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="FILE.yaml",
        help="the scene file to write; its name is the "
        "scene's name; the preview FILE.png and the transcript FILE.transcript.json go next to it",
    )
    parser.add_argument("--objects", nargs="+", metavar="NAME", help="catalog objects the scene must contain")
    parser.add_argument(
        "--method",
        choices=("solver", "grid"),
        default="solver",
        help="solver: relations, solvers, physics and feedback rounds (default); grid: RoboLab's "
        "single-pass baseline (objects on an R x C grid, quarter-cell jitter, no stacking)",
    )
    parser.add_argument("--rounds", type=int, default=4, help="at most this many answers of the model (default 4)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the solver's random choices (default 0)")
    parser.add_argument("--no-preview", action="store_true", help="skip the rendered preview image")
    add_endpoint_arguments(parser)


def run_scene(args: argparse.Namespace) -> int:
    from robolab_ms.catalog import load_catalog
    from robolab_ms.errors import RoboLabError, make_folder
    from robolab_ms.generation.offline import OfflineSceneModel
    from robolab_ms.generation.scene import generate_scene

    if args.rounds < 1:
        raise RoboLabError(f"--rounds {args.rounds}: give at least 1")
    make_folder(Path(args.out).parent, "--out")
    catalog = load_catalog()
    model = OfflineSceneModel(catalog) if args.llm == "offline" else chat_client_from_args(args)
    result = generate_scene(
        args.prompt,
        Path(args.out),
        model,
        method=args.method,
        objects=args.objects,
        rounds=args.rounds,
        seed=args.seed,
        render=not args.no_preview,
        catalog=catalog,
    )
    settled = result.settled
    if settled is not None:
        held = f", {result.satisfied()} of {len(result.requested)} requested relations hold" if result.requested else ""
        worst = max(settled.drift.values(), default=0.0)
        print(
            f"{len(result.objects)} objects, largest drift {worst * 100:.1f} cm over {STABILITY_PHYSICS_STEPS} "
            f"physics steps{held}; {result.rounds} round(s), {result.seconds:.1f} s"
        )
    for line in result.relaxed:
        print(f"relaxed: {line}")
    if not result.accepted:
        print(
            f"robolab: error: no scene after {result.rounds} round(s): " + "; ".join(result.problems), file=sys.stderr
        )
        print(f"transcript: {result.transcript}", file=sys.stderr)
        return 1
    print(f"scene: {result.scene_file}")
    if result.preview:
        print(f"preview: {result.preview}")
    print(f"transcript: {result.transcript}")
    return 0


def add_task_arguments(parser: argparse.ArgumentParser) -> None:
    from robolab_ms.content import CONTENT_ENV
    from robolab_ms.generation.task import DEFAULT_ROUNDS, DEFAULT_SEEDS

    parser.add_argument(
        "scene",
        metavar="SCENE",
        help="the scene: a name as `robolab list` shows them (shipped, or "
        "in a content folder) or a scene file, e.g. my_content/scene_builders/tea.yaml",
    )
    parser.add_argument(
        "instruction",
        metavar="INSTRUCTION",
        help='what the robot should do, e.g. "Put the banana in the bowl"; it becomes the task\'s default instruction',
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="FILE.yaml",
        help="the task file to write (only when every "
        "check passed); its name is the task's name; the transcript FILE.transcript.json goes next "
        "to it. In DIR/task_specs/ of a content folder the task is listed and evaluated like the "
        "shipped ones",
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=DEFAULT_ROUNDS,
        help=f"at most this many answers of the model (default {DEFAULT_ROUNDS})",
    )
    parser.add_argument(
        "--seeds",
        type=int,
        default=DEFAULT_SEEDS,
        help=f"seeds of the `robolab validate` check in each round (default {DEFAULT_SEEDS}; 0 skips "
        "it, and the task is then not proven solvable)",
    )
    parser.add_argument("--seed", type=int, default=0, help="first validation seed (default 0)")
    parser.add_argument(
        "--judge",
        choices=("auto", "model", "rules"),
        default="auto",
        help="who checks that the condition matches the instruction: model (the --llm endpoint), "
        "rules (offline rules), auto (model with --llm openai, rules with --llm offline; "
        "default)",
    )
    parser.add_argument(
        "--content",
        action="append",
        default=[],
        metavar="DIR",
        help=f"a folder of your own tasks and scenes, added after those of ${CONTENT_ENV} (where "
        "SCENE may live); may be given more than once",
    )
    parser.add_argument("--progress", action="store_true", help="show the validation episodes' progress bars")
    add_endpoint_arguments(parser)


def run_task(args: argparse.Namespace) -> int:
    from robolab_ms.catalog import load_catalog
    from robolab_ms.errors import RoboLabError, make_folder
    from robolab_ms.generation.judge import ModelJudge, RulesJudge
    from robolab_ms.generation.offline_task import OfflineTaskModel
    from robolab_ms.generation.task import generate_task, resolve_scene

    make_folder(Path(args.out).parent, "--out")
    catalog = load_catalog()
    scene = resolve_scene(args.scene)
    model = OfflineTaskModel(catalog, scene) if args.llm == "offline" else chat_client_from_args(args)
    use_model = args.judge == "model" or (args.judge == "auto" and args.llm == "openai")
    if use_model and args.llm == "offline":
        raise RoboLabError("--judge model needs an LLM endpoint (--llm openai); with --llm offline use --judge rules")
    judge = ModelJudge(model, catalog) if use_model else RulesJudge(catalog)
    result = generate_task(
        scene,
        args.instruction,
        Path(args.out),
        model,
        judge,
        rounds=args.rounds,
        seeds=args.seeds,
        first_seed=args.seed,
        catalog=catalog,
        show_progress=args.progress,
    )
    if result.judgement is not None:
        notes = f": {'; '.join(result.judgement.problems)}" if result.judgement.problems else ""
        print(f"judge ({result.judgement.judge}): {result.judgement.verdict}{notes}")
    row = result.validation
    if row is not None:
        print(
            f"validate ({row.seeds} seed(s)): oracle {row.oracle_success:.0%}, random policy "
            f"{row.random_success:.0%}, solved at reset {row.success_at_reset}, largest drift {row.max_drift_cm:g} "
            f"cm{'' if row.passed else ' - ' + row.problems}"
        )
    print(f"{result.rounds} round(s), {result.seconds:.1f} s ({result.validate_seconds:.1f} s validating)")
    if not result.accepted:
        print(
            f"robolab: error: no task after {result.rounds} round(s), stopped at the {result.stopped_at} check: "
            + "; ".join(result.problems),
            file=sys.stderr,
        )
        print(f"transcript: {result.transcript}", file=sys.stderr)
        return 1
    print(f"task: {result.task_file} (RoboLab-{result.task_file.stem}-v1)")
    print(f"transcript: {result.transcript}")
    return 0
