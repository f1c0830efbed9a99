"""RoboLab's own run folders (`episode_results.jsonl`, written here in RoboLab's documented format) read by
`robolab analyze` and `robolab leaderboard` beside a robolab_ms run of the same policy: the fields as they map,
the tables' numbers worked out by hand, and the errors a bad file gets."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pandas as pd
import pytest

from robolab_ms.analysis.paired import compare_policies
from robolab_ms.analysis.robolab_results import read_robolab_folder, robolab120_task_rows
from robolab_ms.cli import main as robolab
from robolab_ms.errors import RoboLabError
from robolab_ms.eval.results import EpisodeResult, append_result

ROBOLAB_FOLDER = "2026-03-01_10-00-00_pi05"  # RoboLab's <timestamp>_<policy>[_<instruction_type>]
ISAAC = "pi05@robolab-isaac"
DT = 1 / 15
TIMING = {
    "policy_inference_s": 30.0,
    "policy_inference_avg_ms": 200.0,
    "env_step_s": 60.0,
    "env_step_avg_ms": 400.0,
    "video_write_s": 1.0,
    "video_write_avg_ms": 1.3,
    "wall_total_s": 95.0,
    "it_per_sec": 1.4,
}


def robolab_line(
    task: str,
    run: int,
    env_id: int,
    success: bool,
    score: float | None,
    step: int,
    sparc: float | None,
    path: float,
    events: dict | None = None,
    **extra,
) -> dict:
    """One line of RoboLab's episode_results.jsonl (2 environments per run)."""
    return {
        "env_name": extra.pop("env_name", f"{task}Task"),
        "task_name": f"{task}Task",
        "run_name": f"{task}Task_{run}",
        "run": run,
        "episode": run * 2 + env_id,
        "env_id": env_id,
        "policy": "pi05",
        "instruction": f"do {task}",
        "instruction_type": "default",
        "attributes": ["semantics"],
        "success": success,
        "score": score,
        "reason": "whatever happened",
        "episode_step": step,
        "duration": step * DT,
        "dt": DT,
        "metrics": {
            "ee_sparc": sparc,
            "joint_sparc_mean": -7.5,
            "ee_isj": 12.0,
            "joint_isj": 30.0,
            "ee_path_length": path,
            "ee_speed_max": 0.2,
            "ee_speed_mean": 0.05,
            "joint_rmse_mean": 0.02,
        },
        "events": events or {},
        "timing": TIMING,
        **extra,
    }


# RoboLab: BananaInBowl 2 of 4, RubiksCubeLeftOfBowl 1 of 2
ROBOLAB_LINES = [
    robolab_line("BananaInBowl", 0, 0, True, 1.0, 150, -8.0, 1.2),
    robolab_line("BananaInBowl", 0, 1, False, 0.5, 750, -10.0, 2.0,
                 {"WRONG_OBJECT_GRABBED": 2, "wrong_objects_grabbed": ["bowl", "bowl"], "OBJECT_BUMPED": 1,
                  "TARGET_OBJECT_DROPPED": 1, "WRONG_OBJECT_DETACHED": 1}),
    robolab_line("BananaInBowl", 1, 0, True, None, 300, None, 1.0),  # no score written; SPARC not computed
    robolab_line("BananaInBowl", 1, 1, False, 0.0, 750, -12.0, 0.8),
    robolab_line("RubiksCubeLeftOfBowl", 0, 0, False, 0.25, 450, -9.0, 1.5),
    robolab_line("RubiksCubeLeftOfBowl", 0, 1, True, 1.0, 225, -7.0, 0.5),
]  # fmt: skip
# ours, same policy: BananaInBowl 3 of 4, RubiksCubeLeftOfBowl 1 of 2
OURS = [("BananaInBowl", 0, True, -3.0), ("BananaInBowl", 1, True, -4.0), ("BananaInBowl", 2, False, -5.0),
        ("BananaInBowl", 3, True, -4.0), ("RubiksCubeLeftOfBowl", 0, True, -6.0),
        ("RubiksCubeLeftOfBowl", 1, False, -2.0)]  # fmt: skip


def write_robolab_run(root: Path, lines: list[dict] = ROBOLAB_LINES, name: str = ROBOLAB_FOLDER) -> Path:
    folder = root / name
    folder.mkdir(parents=True)
    (folder / "episode_results.jsonl").write_text("".join(json.dumps(line) + "\n" for line in lines))
    return folder


def write_our_run(root: Path) -> Path:
    folder = root / "ours"
    folder.mkdir(parents=True)
    for task, seed, success, sparc in OURS:
        append_result(
            folder,
            EpisodeResult(
                task=task,
                instruction_variant="default",
                instruction="x",
                robot="droid",
                policy="pi05",
                seed=seed,
                success=success,
                score=1.0 if success else 0.5,
                progress=1.0 if success else 0.5,
                steps=90 if success else 450,
                max_steps=450,
                success_step=89 if success else None,
                wall_seconds=5.0,
                metrics={"ee_sparc": sparc, "ee_path_length": 0.6, "ee_speed_mean": 0.1},
            ),
        )
    return folder


def test_robolab_lines_map_to_our_episode_fields(tmp_path):
    results = {(r.task, r.seed): r for r in read_robolab_folder(write_robolab_run(tmp_path))}
    assert sorted(results) == [
        ("BananaInBowl", 0),
        ("BananaInBowl", 1),
        ("BananaInBowl", 2),
        ("BananaInBowl", 3),
        ("RubiksCubeLeftOfBowl", 0),
        ("RubiksCubeLeftOfBowl", 1),
    ]
    first = results[("BananaInBowl", 0)]
    assert first.policy == ISAAC and first.simulator == "robolab-isaac" and first.robot == "droid"
    assert first.instruction_variant == "default" and first.instruction == "do BananaInBowl"
    assert first.success and first.steps == 150 and first.success_step == 150 and first.max_steps == 50 * 15
    assert first.wall_seconds == 95.0 and first.inference_ms_mean == 200.0 and first.env_step_ms == 400.0
    assert first.steps_per_second == 1.4 and first.condition is None and first.variation == {}
    assert first.metrics["ee_sparc"] == -8.0 and first.metrics["joint_rmse_mean"] == 0.02
    failed = results[("BananaInBowl", 1)]
    assert failed.success_step is None and failed.score == failed.progress == 0.5
    assert failed.event_counts == {"object_bumped": 1, "target_dropped": 1, "wrong_object_grasped": 2}
    assert failed.event_objects == {"wrong_object_grasped": ["bowl"]}
    unscored = results[("BananaInBowl", 2)]
    assert unscored.score == 1.0 and unscored.metrics["ee_sparc"] is None and unscored.success_step == 300
    assert results[("RubiksCubeLeftOfBowl", 0)].max_steps == 30 * 15


def test_variation_runs_get_distinct_seeds_a_condition_and_their_parameters(tmp_path):
    lines = [
        robolab_line(
            "BananaInBowl",
            0,
            env,
            env == 0,
            None,
            100,
            -8.0,
            1.0,
            env_name=f"BananaInBowlTask_{light}",
            lighting_color=color,
            lighting_intensity=100,
        )
        for light, color in (("RedLight", "red"), ("BlueLight", "blue"))
        for env in (0, 1)
    ]
    lines.append(dict(lines[0], success=False))  # the same episode again: the last line counts
    folder = write_robolab_run(tmp_path, lines, "2026-03-01_10-00-00_pi05_vague")
    for line in lines:
        del line["instruction_type"]  # RoboLab leaves it out unless asked: the folder name's suffix says it
    (folder / "episode_results.jsonl").write_text("".join(json.dumps(line) + "\n" for line in lines))
    results = sorted(read_robolab_folder(folder), key=lambda r: r.seed)
    assert [(r.seed, r.condition, r.variation["lighting_color"]) for r in results] == [
        (0, "BlueLight", "blue"),
        (1, "BlueLight", "blue"),
        (2, "RedLight", "red"),
        (3, "RedLight", "red"),
    ]
    assert {r.instruction_variant for r in results} == {"vague"} and not results[2].success


@pytest.fixture(scope="module")
def analyzed(tmp_path_factory) -> tuple[str, Path]:
    """`robolab analyze ROBOLAB_DIR OURS_DIR --by task,simulator --out OUT`: what it printed, and OUT."""
    root = tmp_path_factory.mktemp("beside")
    robolab_dir, ours, out = write_robolab_run(root), write_our_run(root), root / "analysis"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = robolab(
            ["analyze", str(robolab_dir), str(ours), "--by", "task,simulator", "--out", str(out), "--no-plots"]
        )
    assert code == 0
    return printed.getvalue(), out


def test_analyze_puts_a_robolab_run_beside_ours_with_the_numbers_worked_out_by_hand(analyzed):
    printed, out = analyzed
    assert f"| {ISAAC} | 6 | 50.0 [" in printed and "| pi05 | 6 | 66.7 [" in printed
    overall = pd.read_csv(out / "overall.csv").set_index("policy")
    isaac = overall.loc[ISAAC]
    assert (isaac["episodes"], isaac["successes"]) == (6, 3)
    assert isaac["score"] == pytest.approx((1 + 0.5 + 1 + 0 + 0.25 + 1) / 6)  # no score on a success counts 1
    assert isaac["score_fail"] == pytest.approx((0.5 + 0 + 0.25) / 3)
    assert isaac["time_to_success_s"] == pytest.approx((10 + 20 + 15) / 3)  # duration of the successes
    assert isaac["ee_sparc"] == pytest.approx((-8 - 10 - 12 - 9 - 7) / 5)  # the missing SPARC left out
    assert isaac["ee_path_cm"] == pytest.approx(100 * (1.2 + 2.0 + 1.0 + 0.8 + 1.5 + 0.5) / 6)
    assert isaac["wrong_object_grasped"] == pytest.approx(2 / 6) and isaac["target_dropped"] == pytest.approx(1 / 6)
    assert overall.loc["pi05", "ee_sparc"] == pytest.approx(-4.0) and overall.loc["pi05", "successes"] == 4
    by_task = pd.read_csv(out / "by_task.csv").set_index(["policy", "task"])
    assert by_task.loc[(ISAAC, "BananaInBowl"), "success_%"] == 50.0
    assert by_task.loc[("pi05", "BananaInBowl"), "success_%"] == 75.0
    assert by_task.loc[(ISAAC, "RubiksCubeLeftOfBowl"), "ee_sparc"] == pytest.approx(-8.0)
    assert by_task.loc[(ISAAC, "RubiksCubeLeftOfBowl"), "difficulty"] == "moderate"  # from the task files
    by_difficulty = pd.read_csv(out / "by_difficulty.csv").set_index(["policy", "difficulty"])
    assert by_difficulty.loc[(ISAAC, "simple"), "episodes"] == 4
    assert by_difficulty.loc[(ISAAC, "moderate"), "successes"] == 1
    by_simulator = pd.read_csv(out / "by_simulator.csv")
    assert sorted(zip(by_simulator["policy"], by_simulator["simulator"])) == [
        ("pi05", "robolab_ms"),
        (ISAAC, "robolab-isaac"),
    ]
    episodes = pd.read_csv(out / "episodes.csv")
    assert sorted(set(episodes["run"])) == [ROBOLAB_FOLDER, "ours"]


def test_paired_comparison_refuses_episodes_of_two_simulators(analyzed):
    episodes = pd.read_parquet(analyzed[1] / "episodes.parquet")
    with pytest.raises(RoboLabError, match="do not pair"):
        compare_policies(episodes, ISAAC, "pi05")


def test_leaderboard_ranks_a_robolab_run_beside_ours(tmp_path):
    robolab_dir, ours = write_robolab_run(tmp_path), write_our_run(tmp_path)
    site = tmp_path / "site"
    assert robolab(["leaderboard", str(robolab_dir), str(ours), "--out", str(site), "--videos", "none"]) == 0
    markdown = (site / "leaderboard.md").read_text()
    ranking = markdown[: markdown.index("\n\n", markdown.index("| 1 |"))]
    assert ranking.index("| pi05 |") < ranking.index(f"| {ISAAC} |")  # 4 of 6 ranks above 3 of 6
    assert "66.7" in ranking and "50.0" in ranking
    assert (site / "tasks" / "RubiksCubeLeftOfBowl.html").exists()


def test_robolab120_facts_stand_in_for_a_task_without_a_task_file():
    (row,) = robolab120_task_rows(["RubiksCubeLeftOfBowl", "NoSuchTask"])
    assert row["difficulty"] == "moderate" and row["attributes"] == "spatial" and row["axes"] == "relational"
    assert row["episode_seconds"] == 30.0 and row["num_subtasks"] == 3 and row["scene"] == "rubiks_cube_banana_bowl"


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"success": "yes"}, "success"),
        ({"task_name": None, "env_name": None}, "task_name"),
        ({"metrics": {"ee_sparc": "smooth"}}, "metrics.ee_sparc"),
        ({"events": {"OBJECT_BUMPED": -1}}, "events.OBJECT_BUMPED"),
        ({"episode_step": 1.5}, "episode_step"),
    ],
)
def test_a_bad_line_stops_the_command_naming_file_line_and_field(tmp_path, capsys, change, field):
    folder = write_robolab_run(tmp_path, [ROBOLAB_LINES[0], {**ROBOLAB_LINES[1], **change}])
    assert robolab(["analyze", str(folder)]) == 2
    message = capsys.readouterr().err.strip()
    assert message.count("\n") == 0 and "episode_results.jsonl line 2" in message and f"'{field}'" in message


def test_a_line_cut_short_is_skipped_with_a_warning(tmp_path):
    folder = write_robolab_run(tmp_path, ROBOLAB_LINES[:2])
    with (folder / "episode_results.jsonl").open("a") as handle:
        handle.write(json.dumps(ROBOLAB_LINES[2])[:40])
    with pytest.warns(UserWarning, match="line 3"):
        results = read_robolab_folder(folder)
    assert [result.seed for result in results] == [0, 1]
