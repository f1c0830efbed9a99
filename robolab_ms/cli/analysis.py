"""`robolab analyze`, `robolab leaderboard` and `robolab sensitivity`: what results folders say. Each command's
options and its run are in its module of `robolab_ms.analysis`."""

from __future__ import annotations

import argparse


def add_analyze_command(commands, content: argparse.ArgumentParser) -> None:
    """Add `robolab analyze` to the commands."""
    from robolab_ms.analysis import analyze

    analyzing = commands.add_parser(
        "analyze",
        parents=[content],
        help="tables, plots and paired comparisons of results folders",
        description="Success (95 % Beta interval), Score, Score(fail), time to success, SPARC, path length, speed "
        "and event rates per policy, by task, competency axis, attribute, difficulty, scene, instruction variant, "
        "number of objects, episode length, wrong objects grasped or any recorded field; --compare A B: paired "
        "comparison on matched episodes (exact McNemar per task, bootstrap over tasks). See docs/analysis.md.",
    )
    analyze.add_arguments(analyzing)
    analyzing.set_defaults(run=analyze.run)


def add_leaderboard_command(commands, content: argparse.ArgumentParser) -> None:
    """Add `robolab leaderboard` to the commands."""
    from robolab_ms.analysis import leaderboard

    ranking = commands.add_parser(
        "leaderboard",
        parents=[content],
        help="write a static leaderboard site (HTML + Markdown) from results",
        description="Rank the policies of the results folders by overall success (95 % Beta interval; ties by "
        "score) with columns per competency axis and difficulty, one page per task with videos, a Markdown copy, "
        "and with --real-world the sim-to-real correlation. Open SITE_DIR/index.html; no server needed.",
    )
    leaderboard.add_arguments(ranking)
    ranking.set_defaults(run=leaderboard.run)


def add_sensitivity_command(commands, content: argparse.ArgumentParser) -> None:
    """Add `robolab sensitivity` to the commands."""
    from robolab_ms.analysis import sensitivity

    sensitive = commands.add_parser(
        "sensitivity",
        parents=[content],
        help="which varied parameters move a policy's outcome (sbi's MNPE / NPE)",
        description="RoboLab's sensitivity analysis of episodes run with --vary: a neural posterior (MNPE with "
        "categorical parameters, else NPE) of the normalised parameters given the outcomes, sampled at an outcome "
        "(default success = 1); parameters ranked by how far their posterior moves from the prior; marginal and "
        "pairwise plots. See docs/analysis.md.",
    )
    sensitivity.add_arguments(sensitive)
    sensitive.set_defaults(run=sensitivity.run)
