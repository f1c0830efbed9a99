"""The analysis loader: episodes of several folders with their tasks' attributes, and synthetic folders."""

from __future__ import annotations

import json

import pytest

from robolab_ms.analysis.runs import explode_column, load_runs, task_table
from robolab_ms.analysis.synthetic import LIGHT_SPACE, light_dependent_success, write_synthetic_run
from robolab_ms.errors import RoboLabError

TASKS = ["BananaInBowl", "RubiksCubeLeftOfBowl", "BlockStackingSpecifiedOrder"]


def test_load_runs_joins_task_attributes(tmp_path):
    write_synthetic_run(tmp_path / "a", "good", TASKS, 6, 0.8)
    write_synthetic_run(tmp_path / "b", "weak", TASKS, 6, 0.2)
    runs = load_runs([tmp_path / "a", tmp_path / "b"])
    frame = runs.episodes
    assert len(frame) == 2 * 3 * 6 and runs.policies == ["good", "weak"] and runs.unknown_tasks == []
    spec = task_table(["RubiksCubeLeftOfBowl"]).loc["RubiksCubeLeftOfBowl"]
    rows = frame[frame["task"] == "RubiksCubeLeftOfBowl"]
    assert set(rows["scene"]) == {spec["scene"]} and set(rows["difficulty"]) == {spec["difficulty"]}
    assert "spatial" in spec["attributes"].split(";") and set(rows["run"]) == {"a", "b"}
    successes = frame[frame["success"]]
    assert (successes["time_to_success_s"] == successes["success_step"] / 15).all()
    assert frame.loc[~frame["success"], "time_to_success_s"].isna().all()
    by_attribute = explode_column(frame, "attributes")
    assert len(by_attribute) == sum(len(a.split(";")) for a in frame["attributes"])


def test_same_episode_in_two_folders_counts_once(tmp_path):
    write_synthetic_run(tmp_path / "first", "p", TASKS[:1], 4, 0.0)
    write_synthetic_run(tmp_path / "again", "p", TASKS[:1], 4, 1.0)
    frame = load_runs([tmp_path / "first", tmp_path / "again"]).episodes
    assert len(frame) == 4 and frame["success"].all() and set(frame["run"]) == {"again"}


@pytest.mark.slow
def test_unknown_task_is_named_and_kept(tmp_path):
    write_synthetic_run(tmp_path / "x", "p", ["NoSuchTaskAnywhere"], 3, 0.5)
    with pytest.warns(UserWarning, match="NoSuchTaskAnywhere"):
        runs = load_runs([tmp_path / "x"])
    assert runs.unknown_tasks == ["NoSuchTaskAnywhere"] and runs.episodes["scene"].isna().all()


def test_bad_folders_say_what_to_do(tmp_path):
    with pytest.raises(RoboLabError, match="no such folder"):
        load_runs([tmp_path / "missing"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(RoboLabError, match="episodes.jsonl"):
        load_runs([tmp_path / "empty"])
    with pytest.raises(RoboLabError, match="no results folder"):
        load_runs([])


def test_synthetic_parameters_are_shared_across_policies_and_drive_success(tmp_path):
    a = write_synthetic_run(tmp_path / "a", "one", TASKS[:1], 400, light_dependent_success, params=LIGHT_SPACE)
    b = write_synthetic_run(tmp_path / "b", "two", TASKS[:1], 400, light_dependent_success, params=LIGHT_SPACE)
    lines_a = [json.loads(line) for line in (a / "episodes.jsonl").read_text().splitlines()]
    lines_b = [json.loads(line) for line in (b / "episodes.jsonl").read_text().splitlines()]
    assert [x["variation"] for x in lines_a] == [x["variation"] for x in lines_b]
    assert [x["success"] for x in lines_a] != [x["success"] for x in lines_b]  # outcomes drawn per policy
    frame = load_runs([a]).episodes
    bright = frame[frame["light_intensity"] > 1.5]["success"].mean()
    dark = frame[frame["light_intensity"] < 0.5]["success"].mean()
    assert bright > dark + 0.4
