"""`robolab analyze`: tables on synthetic runs with known rates, filters, the command writing files and plots, and
the paired comparison (interval coverage and McNemar's error rates on synthetic outcomes with a known truth)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from robolab_ms.analysis.analyze import GROUPING_NAMES
from robolab_ms.analysis.paired import compare_policies, mcnemar_exact, paired_task_table
from robolab_ms.analysis.report import GROUPINGS, breakdown, filter_episodes, parameter_columns
from robolab_ms.analysis.runs import load_runs
from robolab_ms.analysis.synthetic import LIGHT_SPACE, paired_episode_frame, write_synthetic_run
from robolab_ms.cli import main
from robolab_ms.errors import RoboLabError

# difficulty simple / moderate / complex; axes visual, relational, procedural+visual
RATES = {"BananaInBowl": 0.9, "RubiksCubeLeftOfBowl": 0.5, "BlockStackingSpecifiedOrder": 0.1}
EPISODES = 60


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two synthetic policies on three tasks: `known` with the per-task RATES, `flat` at 0.5; light varied."""
    folder = tmp_path_factory.mktemp("analysis")
    write_synthetic_run(folder / "known", "known", list(RATES), EPISODES, RATES, params=LIGHT_SPACE)
    write_synthetic_run(folder / "flat", "flat", list(RATES), EPISODES, 0.5, params=LIGHT_SPACE)
    return folder, load_runs([folder / "known", folder / "flat"]).episodes


def test_task_table_counts_and_intervals_match_the_known_rates(runs):
    _, episodes = runs
    table = breakdown(episodes, "task").set_index(["policy", "task"])
    for task, rate in RATES.items():
        row = table.loc[("known", task)]
        rows = episodes[(episodes["policy"] == "known") & (episodes["task"] == task)]
        assert row["episodes"] == EPISODES and row["successes"] == rows["success"].sum()
        assert row["success_%"] == pytest.approx(100 * rows["success"].mean())
        assert row["success_ci95_low_%"] <= 100 * rate <= row["success_ci95_high_%"]
        assert row["score_fail"] == pytest.approx(rows.loc[~rows["success"], "score"].mean())
        assert row["time_to_success_s"] == pytest.approx(rows.loc[rows["success"], "success_step"].mean() / 15)
        assert row["wrong_object_grasped"] == pytest.approx(rows["wrong_object_grasped"].mean())
        assert row["difficulty"] == episodes.loc[rows.index[0], "difficulty"]
    overall = breakdown(episodes).set_index("policy")
    assert overall.loc["known", "episodes"] == 3 * EPISODES
    assert overall.loc["known", "success_%"] == pytest.approx(100 * episodes[episodes.policy == "known"].success.mean())


def test_groupings_count_episodes_once_per_axis_and_keep_difficulty_order(runs):
    _, episodes = runs
    known = episodes[episodes["policy"] == "known"]
    by_axis = breakdown(known, "axis").set_index("axis")
    assert by_axis["episodes"].to_dict() == {"procedural": EPISODES, "relational": EPISODES, "visual": 2 * EPISODES}
    visual = known[known["axes"].str.contains("visual")]
    assert by_axis.loc["visual", "successes"] == visual["success"].sum()
    assert list(breakdown(known, "difficulty")["difficulty"]) == ["simple", "moderate", "complex"]
    wrong = breakdown(known, "wrong_objects")
    assert wrong["episodes"].sum() == len(known) and set(wrong["wrong_objects"]) <= {"0", "1", "2", "3+"}
    binned = breakdown(known, "light_intensity", bins=4)
    assert len(binned) == 4 and binned["episodes"].sum() == len(known)
    assert binned["light_intensity_mean"].is_monotonic_increasing
    # the synthetic success does not depend on the light for these runs; each colour is its own group
    assert set(breakdown(known, "light_color")["light_color"]) == set(LIGHT_SPACE["light_color"])
    assert tuple(GROUPINGS) == GROUPING_NAMES
    assert parameter_columns(episodes) == ["cam_external_left_dx", "light_color", "light_intensity"]


def test_filters_keep_what_they_say_and_refuse_unknown_fields(runs):
    _, episodes = runs
    red = filter_episodes(episodes, where=["light_color=red,blue"])
    assert set(red["light_color"]) == {"red", "blue"}
    dim = filter_episodes(episodes, policies=["known"], where=["light_intensity<0.5", "success=false"])
    assert (dim["light_intensity"] < 0.5).all() and not dim["success"].any() and set(dim["policy"]) == {"known"}
    crowded = filter_episodes(episodes, where=["num_objects>=3"])
    assert set(crowded["task"]) == {"RubiksCubeLeftOfBowl", "BlockStackingSpecifiedOrder"}
    assert set(filter_episodes(episodes, attributes=["spatial"])["task"]) == {"RubiksCubeLeftOfBowl"}
    assert set(filter_episodes(episodes, where=["axis=procedural"])["task"]) == {"BlockStackingSpecifiedOrder"}
    assert set(filter_episodes(episodes, where=["difficulty!=complex"])["difficulty"]) == {"simple", "moderate"}
    with pytest.raises(RoboLabError, match="no field 'light_colour'.*Did you mean 'light_color'"):
        filter_episodes(episodes, where=["light_colour=red"])
    with pytest.raises(RoboLabError, match="no episode has light_color=purple"):
        filter_episodes(episodes, where=["light_color=purple"])
    with pytest.raises(RoboLabError, match="holds numbers"):
        filter_episodes(episodes, where=["num_objects>=many"])
    with pytest.raises(RoboLabError, match="FIELD=VALUE"):
        filter_episodes(episodes, where=["light_color"])
    with pytest.raises(RoboLabError, match="--task NoSuchTask: not in these runs"):
        filter_episodes(episodes, tasks=["NoSuchTask"])
    with pytest.raises(RoboLabError, match="leave no episode"):
        filter_episodes(episodes, tasks=["BananaInBowl"], where=["num_objects>=3"])


@pytest.mark.slow
def test_cli_prints_tables_and_writes_csv_parquet_and_plots(runs, tmp_path, capsys):
    folder, _ = runs
    out = tmp_path / "report"
    code = main(
        [
            "analyze",
            str(folder / "known"),
            str(folder / "flat"),
            "--where",
            "light_intensity>0.1",
            "--by",
            "task,light_color",
            "--compare",
            "known",
            "flat",
            "--resamples",
            "500",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert (
        "## By task" in printed and "## By light_color" in printed and "## Paired comparison: known vs flat" in printed
    )
    for name in (
        "overall",
        "by_task",
        "by_axis",
        "by_attribute",
        "by_difficulty",
        "by_scene",
        "by_variant",
        "by_num_objects",
        "by_episode_length",
        "by_wrong_objects",
        "by_light_intensity",
        "paired_tasks",
    ):
        from_csv, from_parquet = pd.read_csv(out / f"{name}.csv"), pd.read_parquet(out / f"{name}.parquet")
        assert len(from_csv) == len(from_parquet) > 0 and ("episodes" in from_csv or "pairs" in from_csv)
    by_task = pd.read_parquet(out / "by_task.parquet")
    assert {"success_ci95_low_%", "score_fail", "ee_sparc", "ee_path_cm", "object_bumped"} <= set(by_task.columns)
    episodes = pd.read_parquet(out / "episodes.parquet")
    assert (episodes["light_intensity"] > 0.1).all()
    for plot in (
        "success_by_axis",
        "success_by_difficulty",
        "score_vs_complexity",
        "success_heatmap",
        "success_by_parameter",
        "paired_difference",
    ):
        png, svg = (out / "plots" / f"{plot}.png").read_bytes(), (out / "plots" / f"{plot}.svg").read_text()
        assert png.startswith(b"\x89PNG") and len(png) > 5000 and "<svg" in svg
        width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
        assert width > 300 and height > 150


@pytest.mark.slow
def test_cli_errors_say_what_to_do(runs, tmp_path, capsys):
    folder, _ = runs
    write_synthetic_run(tmp_path / "other", "other", ["MarkerInMug"], 5, 0.5)
    assert main(["analyze", str(folder / "known"), str(tmp_path / "other"), "--compare", "known", "other"]) == 2
    assert "no episode of known has a partner of other" in capsys.readouterr().err
    assert main(["analyze", str(folder / "known"), "--by", "lightcolor"]) == 2
    assert "no field 'lightcolor'" in capsys.readouterr().err
    assert main(["analyze", str(folder / "known"), "--compare"]) == 2
    assert "exactly two policies" in capsys.readouterr().err


# drawn parameters as `robolab eval --vary lighting,objects` records them: the Rubik's cube of RubiksCubeLeftOfBowl is
# in no scene of BananaInBowl, so its offsets are missing from BananaInBowl's lines
DRAWN = {
    "BananaInBowl": [{"light_color": "blue", "light_intensity": 0.8472, "obj_banana_dx": -0.09221, "obj_bowl_dx": 0.07953},
                     {"light_color": "blue", "light_intensity": 1.381, "obj_banana_dx": 0.06941, "obj_bowl_dx": -0.05252},
                     {"light_color": "green", "light_intensity": 0.1544, "obj_banana_dx": 0.03099,
                      "obj_bowl_dx": -0.09764}],
    "RubiksCubeLeftOfBowl": [{"light_color": "blue", "light_intensity": 0.8472, "obj_banana_dx": -0.02242,
                              "obj_bowl_dx": 0.0456, "obj_rubiks_cube_dx": -0.04703},
                             {"light_color": "blue", "light_intensity": 1.381, "obj_banana_dx": 0.06941,
                              "obj_bowl_dx": -0.05252, "obj_rubiks_cube_dx": -0.04852},
                             {"light_color": "green", "light_intensity": 0.1544, "obj_banana_dx": 0.03099,
                              "obj_bowl_dx": -0.09764, "obj_rubiks_cube_dx": -0.06039}],
}  # fmt: skip


def _write_varied_run(folder, policy: str, success: bool) -> None:
    """Three episodes per task of DRAWN, written with the results writer of `robolab eval`."""
    from robolab_ms.eval.results import EpisodeResult, append_result

    folder.mkdir(parents=True)
    for task, draws in DRAWN.items():
        for seed, drawn in enumerate(draws):
            append_result(
                folder,
                EpisodeResult(
                    task=task,
                    instruction_variant="default",
                    instruction="(test)",
                    robot="droid",
                    policy=policy,
                    seed=seed,
                    success=success,
                    score=1.0 if success else 0.0,
                    progress=1.0 if success else 0.0,
                    steps=120,
                    max_steps=750,
                    success_step=120 if success else None,
                    wall_seconds=1.5,
                    metrics={"ee_sparc": -3.5, "ee_path_length": 0.8},
                    variations="lighting,objects",
                    variation=dict(drawn),
                ),
            )


def test_parameter_drawn_for_one_task_only_is_plotted_from_its_episodes(tmp_path, capsys):
    _write_varied_run(tmp_path / "oracle", "oracle", True)
    _write_varied_run(tmp_path / "random", "random", False)
    out = tmp_path / "report"
    assert main(["analyze", str(tmp_path / "oracle"), str(tmp_path / "random"), "--out", str(out)]) == 0
    capsys.readouterr()
    svg = (out / "plots" / "success_by_parameter.svg").read_text()
    assert "obj_rubiks_cube_dx" in svg and "6 of 12 episodes" in svg and "obj_banana_dx" in svg
    table = pd.read_csv(out / "by_obj_rubiks_cube_dx.csv")
    assert table["episodes"].sum() == 12 and table["obj_rubiks_cube_dx"].isna().sum() == 2  # one group per policy
    assert table.loc[table["obj_rubiks_cube_dx"].isna(), "episodes"].tolist() == [3, 3]


@pytest.mark.slow
def test_paired_comparison_on_files_finds_the_known_difference(tmp_path):
    tasks = list(RATES)
    write_synthetic_run(tmp_path / "a", "a", tasks, 40, {t: 0.9 for t in tasks})
    write_synthetic_run(
        tmp_path / "b",
        "b",
        tasks,
        40,
        {"BananaInBowl": 0.2, "RubiksCubeLeftOfBowl": 0.9, "BlockStackingSpecifiedOrder": 0.9},
    )
    result = compare_policies(load_runs([tmp_path / "a", tmp_path / "b"]).episodes, "a", "b", resamples=500)
    rows = result.per_task.set_index("task")
    assert rows.loc["BananaInBowl", "significant"] and rows.loc["BananaInBowl", "winner"] == "a"
    assert rows.loc["BananaInBowl", "ci_low_%"] <= 70 <= rows.loc["BananaInBowl", "ci_high_%"]
    assert not rows.loc["RubiksCubeLeftOfBowl", "significant"]
    assert result.overall["pairs"] == 120 and result.overall["a_wins_significant"] >= 1


def test_paired_intervals_cover_the_true_difference():
    """200 synthetic comparisons of 30 tasks x 20 pairs; per task p_A ~ U(0.45, 0.95), p_B = p_A - U(0, 0.4), so
    the mean difference over the population of tasks is 0.2. The 95 % intervals must contain the truth in 90-99 %
    of cases: the bootstrap over tasks (the population mean) and every per-task Newcombe interval."""
    rng = np.random.default_rng(2024)
    repetitions, tasks, pairs = 200, 30, 20
    overall_hits, task_hits = 0, 0
    for repetition in range(repetitions):
        rate_a = rng.uniform(0.45, 0.95, tasks)
        gap = rng.uniform(0.0, 0.4, tasks)
        result = compare_policies(
            paired_episode_frame(rng, rate_a, rate_a - gap, pairs), "a", "b", resamples=1000, seed=repetition
        )
        overall_hits += result.overall["ci_low_%"] <= 20.0 <= result.overall["ci_high_%"]
        rows = result.per_task  # sorted by task name = the order drawn
        task_hits += int(((rows["ci_low_%"] <= 100 * gap + 1e-9) & (100 * gap <= rows["ci_high_%"] + 1e-9)).sum())
    assert 0.90 <= overall_hits / repetitions <= 0.99, overall_hits / repetitions
    assert 0.90 <= task_hits / (repetitions * tasks) <= 0.99, task_hits / (repetitions * tasks)


def test_mcnemar_finds_a_large_difference_and_rarely_a_null_one():
    rng = np.random.default_rng(7)
    null = paired_task_table(
        paired_episode_frame(rng, np.full(400, 0.6), np.full(400, 0.6), 30)
        .pivot_table(index=["task", "seed"], columns="policy", values="success")
        .rename(columns={"a": "success_a", "b": "success_b"})
        .reset_index()
    )
    assert (null["p_mcnemar"] < 0.05).mean() <= 0.06  # exact test: at most its level (here about 0.03)
    large = paired_task_table(
        paired_episode_frame(rng, np.full(400, 0.9), np.full(400, 0.3), 30)
        .pivot_table(index=["task", "seed"], columns="policy", values="success")
        .rename(columns={"a": "success_a", "b": "success_b"})
        .reset_index()
    )
    assert (large["p_mcnemar"] < 0.05).mean() >= 0.95
    from scipy.stats import binomtest

    counts = [(k, m - k) for m in range(1, 25) for k in range(m + 1)]
    expected = [binomtest(k, k + rest, 0.5).pvalue for k, rest in counts]
    assert np.allclose(mcnemar_exact(*np.array(counts).T), expected)
