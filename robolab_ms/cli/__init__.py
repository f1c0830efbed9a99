"""The `robolab` command line: list tasks, evaluate policies, validate tasks, build and check the catalog.

Examples:
  robolab list
  robolab eval --policy random --task BananaInBowl --episodes 2 --out results/demo
  robolab catalog build | check [--objects NAME ...] | sheet | list
  robolab scene export kitchen_table --usd out/kitchen_table.usda   # and: robolab scene import FILE.usda
  robolab eval --policy oracle --task BananaInBowl --episodes 10
  robolab validate --task BananaInBowl --seeds 10
  robolab eval --policy oracle --task BananaInBowl --vary lighting,objects=0.2   # domain randomization
  robolab suites                                        # then: robolab eval --suite lighting ...
  robolab serve --policy random --port 8000            # then: robolab eval --policy openpi --port 8000 ...
  robolab eval --policy random --task all --episodes 20 --workers 2    # or --ray ADDRESS / auto / local
  robolab export lerobot results/demo datasets/demo     # episodes recorded with --record-images

One module per group of commands, each with its parser builder and command functions: `.tasks` (list),
`.evaluate` (eval, suites, serve), `.recordings` (replay, export), `.generate`, `.catalog`, `.scene` (scene,
render-check), `.validate` and `.analysis` (analyze, leaderboard, sensitivity); `.common` holds the options and
helpers several of them share.
"""

from __future__ import annotations

import argparse
import sys

from robolab_ms.cli import analysis, catalog, evaluate, generate, recordings, scene, tasks, validate
from robolab_ms.cli.common import content_parent
from robolab_ms.errors import RoboLabError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="robolab",
        description="RoboLab benchmark on ManiSkill3: list tasks, evaluate policies, validate tasks, build and check the object catalog.",
        epilog="Environments are also usable directly: gym.make('RoboLab-<Task>-v1') after importing mani_skill.envs.",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    content = content_parent()
    # in this order in `robolab --help`
    tasks.add_list_command(commands, content)
    evaluate.add_eval_command(commands, content)
    recordings.add_replay_command(commands)
    recordings.add_export_command(commands)
    generate.add_generate_command(commands)
    evaluate.add_serve_command(commands)
    catalog.add_catalog_command(commands)
    scene.add_scene_command(commands, content)
    validate.add_validate_command(commands, content)
    evaluate.add_suites_command(commands)
    scene.add_render_check_command(commands)
    analysis.add_analyze_command(commands, content)
    analysis.add_leaderboard_command(commands, content)
    analysis.add_sensitivity_command(commands, content)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        from robolab_ms.content import add_content_root

        for folder in getattr(args, "content", None) or []:
            add_content_root(folder)
        code = args.run(args)
        sys.stdout.flush()  # here, so that a reader gone away (`robolab list | head`) is caught below
        return code
    except RoboLabError as error:
        print(f"robolab: error: {error}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader of stdout stopped reading: nothing more to say to it
        _stdout_to_devnull()
        return 1


def _stdout_to_devnull() -> None:
    """Point stdout at the null device, so that flushing it at exit does not fail on a closed pipe again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout without a file descriptor (captured): nothing to redirect
        pass
