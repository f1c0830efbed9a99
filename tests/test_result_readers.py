"""The result readers on results folders broken the ways files get broken, on partial folders and on folders of
earlier versions: `robolab analyze`, `sensitivity`, `leaderboard`, `eval` (resuming), `export lerobot` and
`load_runs` either give the right tables (exit 0) or stop with one message naming the file, the line and the
field (exit 2), never a traceback."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import h5py
import pandas as pd
import pytest

from robolab_ms.analysis.runs import load_runs
from robolab_ms.analysis.synthetic import write_synthetic_run
from robolab_ms.cli import main
from robolab_ms.errors import ResultsError

ROBOLAB = str(Path(sys.executable).with_name("robolab"))
TASKS = ("BananaInBowl", "RubiksCubeLeftOfBowl")
EVAL = ("eval", "--policy", "random", "--task", *TASKS, "--episodes", "2", "--max-steps", "5", "--vary", "lighting",
        "--quiet")  # fmt: skip
# the fields of a result line in earlier versions, from the history of eval/results.py: the first version (commit
# 460f345, robot "panda" by default) and the one before variations were recorded (f554d3e)
FIRST_VERSION_FIELDS = ("task", "instruction_variant", "instruction", "robot", "policy", "seed", "success", "score",
                        "progress", "steps", "max_steps", "success_step", "wall_seconds", "error", "events", "metrics",
                        "version")  # fmt: skip
ADDED_WITH_VARIATIONS = ("variations", "condition", "variation")
LINE_FIX = "Correct the line or delete it"


@pytest.fixture(scope="module")
def valid(tmp_path_factory) -> Path:
    """A small real results folder: the random policy on two tasks, two episodes of 5 steps each, lighting varied,
    trajectories recorded."""
    folder = tmp_path_factory.mktemp("readers") / "valid"
    assert main([*EVAL, "--record", "--out", str(folder)]) == 0
    return folder


def robolab(capsys, *args: object) -> tuple[int, str]:
    """`robolab ARGS` in this process: its exit code and what it printed. An exception escaping the command (a
    traceback for the user) fails the test; an error (exit 2) must be one message on one line."""
    try:
        code = main([str(arg) for arg in args])
    except SystemExit as exit:  # argparse's usage errors
        code = exit.code
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    if code == 2:
        assert len([line for line in err.splitlines() if line.startswith("robolab: error:")]) == 1, err
    return code, out + err


def copy_results(valid: Path, target: Path, recordings: bool = False) -> Path:
    ignore = shutil.ignore_patterns(".writer.lock", *([] if recordings else ["recordings"]))
    shutil.copytree(valid, target, ignore=ignore)
    return target


def read_lines(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines()]


def dump(lines: list) -> str:
    return "".join(json.dumps(line) + "\n" for line in lines)


def edit(index: int, change: Callable[[dict], None]) -> Callable[[list[dict]], str]:
    """A file edit: `change` applied to the line at `index` (0-based)."""

    def apply(lines: list[dict]) -> str:
        change(lines[index])
        return dump(lines)

    return apply


def put(key: str, value: object) -> Callable[[dict], None]:
    """Set `key` (`metrics.ee_sparc`: an entry of an object field) of a line to `value`."""

    def change(line: dict) -> None:
        *parents, last = key.split(".")
        target = line
        for parent in parents:
            target = target[parent]
        target[last] = value

    return change


def drop(key: str) -> Callable[[dict], None]:
    return lambda line: line.pop(key)


def keep_only(names: tuple[str, ...], **values: object) -> Callable[[list[dict]], str]:
    """Every line as an earlier version wrote it: only the fields `names`, with `values` set."""
    return lambda lines: dump([{**{k: v for k, v in line.items() if k in names}, **values} for line in lines])


@dataclass
class Case:
    name: str
    change: Callable[[list[dict]], str]
    error: tuple[int, str] | None = None  # (line, field) named by the error; None: the tables are written
    episodes: int = 4  # episodes in the tables when they are written


NAN, INF = float("nan"), float("inf")
CASES = [
    # the tables are written
    Case("NaN metric", edit(1, put("metrics.ee_sparc", NAN))),
    Case("null metrics and events", edit(1, lambda line: line.update(metrics=None, events=None, event_counts=None))),
    Case("NaN and null variation parameters", edit(1, lambda line: line["variation"].update(
        light_intensity=NAN, light_color=None))),
    Case("unknown extra fields", edit(2, lambda line: line.update(future_field={"nested": [1, 2]},
                                                                  metrics={**line["metrics"], "future_metric": 1.5}))),
    Case("truncated last line", lambda lines: dump(lines)[:-40], episodes=3),
    Case("half-written line, then a resumed run", lambda lines: dump(lines[:1])[:80] + "\n" + dump(lines[1:]),
         episodes=3),
    Case("blank lines and CRLF", lambda lines: "\n" + dump(lines).replace("\n", "\r\n\r\n")),
    Case("an episode run again", lambda lines: dump([*lines, {**lines[0], "error": None, "score": 0.5}])),
    Case("first version (no tallies, robot panda)", keep_only(FIRST_VERSION_FIELDS, robot="panda", metrics={})),
    Case("version before variations", lambda lines: dump([{k: v for k, v in line.items()
                                                            if k not in ADDED_WITH_VARIATIONS} for line in lines])),
    # one message naming the line and the field
    Case("NaN score", edit(1, put("score", NAN)), (2, "score")),
    Case("Infinity progress", edit(1, put("progress", INF)), (2, "progress")),
    Case("missing success", edit(2, drop("success")), (3, "success")),
    Case("missing task", edit(0, drop("task")), (1, "task")),
    Case("null task", edit(1, put("task", None)), (2, "task")),
    Case("text score", edit(1, put("score", "0.5")), (2, "score")),
    Case("text seed", edit(3, put("seed", "3")), (4, "seed")),
    Case("text success", edit(1, put("success", "yes")), (2, "success")),
    Case("text steps", edit(1, put("steps", "many")), (2, "steps")),
    Case("negative steps", edit(1, put("steps", -3)), (2, "steps")),
    Case("text metric", edit(1, put("metrics.ee_sparc", "smooth")), (2, "metrics.ee_sparc")),
    Case("metrics a list", edit(1, put("metrics", [1, 2])), (2, "metrics")),
    Case("object as variation parameter", edit(1, put("variation.light_color", {"r": 1})), (2, "variation.light_color")),
    Case("event without a type", edit(1, put("events", [{"step": 3}])), (2, "events")),
    Case("line not an object", lambda lines: dump(lines) + "[1, 2]\n", (5, "")),
]  # fmt: skip


def _table_check(case: Case, lines: list[dict], out: Path) -> None:
    """The overall table of `robolab analyze --out` holds what the readable lines say."""
    overall = pd.read_csv(out / "overall.csv")
    assert overall["episodes"].sum() == case.episodes
    episodes = pd.read_parquet(out / "episodes.parquet")
    assert len(episodes) == case.episodes
    if case.name == "NaN metric":
        others = [line["metrics"]["ee_sparc"] for i, line in enumerate(lines) if i != 1]
        assert overall["ee_sparc"].iloc[0] == pytest.approx(sum(others) / len(others))
    if case.name == "an episode run again":  # the later line counts
        row = episodes[(episodes["task"] == lines[0]["task"]) & (episodes["seed"] == lines[0]["seed"])]
        assert row["score"].tolist() == [0.5]
    if case.name.startswith("first version"):
        assert set(episodes["robot"]) == {"panda"} and episodes["ee_sparc"].isna().all()
    if case.name.startswith("NaN and null variation"):
        assert episodes["light_intensity"].isna().sum() == 1 and episodes["light_color"].isna().sum() == 1
        assert "3 of 4 episodes" in (out / "plots" / "success_by_parameter.svg").read_text()


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_readers_on_a_broken_episode_file(case, valid, tmp_path, capsys):
    folder = copy_results(valid, tmp_path / "run")
    lines = read_lines(folder)
    (folder / "episodes.jsonl").write_bytes(case.change(read_lines(folder)).encode())
    analyze = robolab(capsys, "analyze", folder, "--out", tmp_path / "analysis")
    leaderboard = robolab(capsys, "leaderboard", folder, "--out", tmp_path / "site")
    sensitivity = robolab(capsys, "sensitivity", folder, "--out", tmp_path / "sensitivity")
    if case.error is None:
        assert analyze[0] == 0 and leaderboard[0] == 0, analyze[1] + leaderboard[1]
        _table_check(case, lines, tmp_path / "analysis")
        assert (tmp_path / "site" / "index.html").exists()
        assert sensitivity[0] == 2  # 4 episodes are too few to fit (and the random policy never succeeds)
        assert len(load_runs([folder]).episodes) == case.episodes
        return
    line, field = case.error
    resumed = robolab(capsys, *EVAL, "--out", folder)  # a rerun would resume after the complete lines
    for code, printed in (analyze, leaderboard, sensitivity, resumed):
        assert code == 2
        assert f"{folder / 'episodes.jsonl'} line {line}" in printed and LINE_FIX in printed
        assert (f"field '{field}'" in printed) if field else ("field" not in printed.split(LINE_FIX)[0])
    with pytest.raises(ResultsError) as raised:
        load_runs([folder])
    assert (raised.value.line, raised.value.field) == (line, field)


def test_line_that_is_not_utf8_is_named(valid, tmp_path, capsys):
    folder = copy_results(valid, tmp_path / "run")
    with (folder / "episodes.jsonl").open("ab") as handle:
        handle.write(b'{"task": "Caf\xe9"}\n')
    code, printed = robolab(capsys, "analyze", folder)
    assert code == 2 and "line 5: is not UTF-8 text" in printed


@pytest.mark.parametrize("damage", ["no manifest", "truncated manifest", "manifest not an object"])
def test_folder_without_a_readable_manifest_is_read(damage, valid, tmp_path, capsys):
    folder = copy_results(valid, tmp_path / "run")
    manifest = folder / "manifest.json"
    if damage == "no manifest":
        manifest.unlink()
    else:
        manifest.write_text(manifest.read_text()[:50] if damage == "truncated manifest" else "[1, 2]")
    assert robolab(capsys, "analyze", folder, "--out", tmp_path / "analysis")[0] == 0
    assert pd.read_csv(tmp_path / "analysis" / "overall.csv")["episodes"].sum() == 4
    assert robolab(capsys, "leaderboard", folder, "--out", tmp_path / "site")[0] == 0
    assert robolab(capsys, "sensitivity", folder)[0] == 2


@pytest.mark.parametrize("state", ["no episodes file", "empty episodes file", "only a partial line",
                                   "episodes file is a folder", "a file, not a folder"])  # fmt: skip
def test_partial_folders_are_named_with_what_to_do(state, valid, tmp_path, capsys):
    folder = copy_results(valid, tmp_path / "run")
    episodes = folder / "episodes.jsonl"
    expected = {"no episodes file": "no episodes.jsonl in it", "empty episodes file": "no complete episode",
                "only a partial line": "no complete episode", "episodes file is a folder": "cannot be read",
                "a file, not a folder": "a file, not a folder"}[state]  # fmt: skip
    if state == "no episodes file":
        episodes.unlink()
    elif state == "empty episodes file":
        episodes.write_text("")
    elif state == "only a partial line":
        episodes.write_text(episodes.read_text()[:100])
    elif state == "episodes file is a folder":
        episodes.unlink()
        episodes.mkdir()
    else:
        folder = episodes
    for command in ("analyze", "leaderboard", "sensitivity"):
        extra = ("--out", tmp_path / "site") if command == "leaderboard" else ()
        code, printed = robolab(capsys, command, folder, *extra)
        assert code == 2 and expected in printed, printed


def test_sensitivity_on_parameters_of_some_tasks_and_a_malformed_manifest(tmp_path, capsys):
    """Enough episodes to fit: a parameter recorded for one task's episodes only is left out with a note, and
    manifest ranges of the wrong shape fall back to the axis defaults."""
    folder = write_synthetic_run(tmp_path / "run", "p", list(TASKS), 15, 0.5, params={"light_intensity": (0.1, 2.0)})
    lines = read_lines(folder)
    for line in lines:
        if line["task"] == TASKS[1]:
            line["variation"]["obj_rubiks_cube_dx"] = 0.01 * line["seed"]
    (folder / "episodes.jsonl").write_text(dump(lines))
    (folder / "manifest.json").write_text(json.dumps({"variations": {"ranges": {"lighting": "0.1:2"}}}))
    code, printed = robolab(capsys, "sensitivity", folder, "--epochs", "2", "--samples", "200", "--out",
                            tmp_path / "sensitivity")  # fmt: skip
    assert code == 0, printed
    assert "left out, recorded for some episodes only: obj_rubiks_cube_dx" in printed
    table = pd.read_csv(tmp_path / "sensitivity" / "sensitivity.csv")
    assert table["parameter"].tolist() == ["light_intensity"] and table["range_source"].tolist() == ["axis default"]
    code, printed = robolab(capsys, "sensitivity", folder, "--params", "obj_rubiks_cube_dx")
    assert code == 2 and "15 usable episode(s)" in printed  # the episodes that have it: too few


def _recording(folder: Path, suffix: str) -> Path:
    return min((folder / "recordings").rglob(f"*{suffix}"))


def _set_meta(key: str, value: object) -> Callable[[Path], None]:
    def change(folder: Path) -> None:
        path = _recording(folder, ".json")
        meta = json.loads(path.read_text())
        meta["robolab"][key] = value
        path.write_text(json.dumps(meta))

    return change


def _drop_dataset(name: str) -> Callable[[Path], None]:
    def change(folder: Path) -> None:
        with h5py.File(_recording(folder, ".h5"), "a") as file:
            del file[f"traj_0/{name}"]

    return change


RECORDING_CASES = {
    "valid": (lambda folder: None, None),
    "no robolab block (skipped)": (lambda folder: _recording(folder, ".json").write_text('{"episodes": []}'), None),
    "truncated .json": (lambda folder: _recording(folder, ".json").write_text(
        _recording(folder, ".json").read_text()[:120]), ("", ".json")),
    ".json not an object": (lambda folder: _recording(folder, ".json").write_text("[1, 2]"), ("", ".json")),
    "text control rate": (_set_meta("control_hz", "fast"), ("robolab.control_hz", ".json")),
    "NaN seed": (_set_meta("seed", NAN), ("robolab.seed", ".json")),
    "cameras as text": (_set_meta("cameras", "wrist"), ("robolab.cameras", ".json")),
    "score as text": (_set_meta("score", "high"), ("robolab.score", ".json")),
    ".h5 not HDF5": (lambda folder: _recording(folder, ".h5").write_bytes(b"not hdf5"), ("", ".h5")),
    ".h5 truncated": (lambda folder: _recording(folder, ".h5").write_bytes(_recording(folder, ".h5").read_bytes()[:4096]),
                      ("", ".h5")),
    ".h5 without actions": (_drop_dataset("actions"), ("traj_0/actions", ".h5")),
    ".h5 without joint positions": (_drop_dataset("robolab/joint_position"), ("traj_0/robolab/joint_position", ".h5")),
}  # fmt: skip


@pytest.mark.parametrize("case", list(RECORDING_CASES))
def test_export_lerobot_on_damaged_recordings(case, valid, tmp_path, capsys):
    folder = copy_results(valid, tmp_path / "run", recordings=True)
    damage, error = RECORDING_CASES[case]
    damage(folder)
    code, printed = robolab(capsys, "export", "lerobot", folder, tmp_path / "dataset", "--no-videos")
    if error is None:
        assert code == 0, printed
        exported = 3 if "skipped" in case else 4
        assert f"{exported} episode(s)" in printed
        info = json.loads((tmp_path / "dataset" / "meta" / "info.json").read_text())
        assert info["total_episodes"] == exported and info["total_frames"] == 5 * exported
        return
    field, suffix = error
    assert code == 2 and str(_recording(folder, suffix)) in printed and "Record the episode again" in printed
    assert (f"field '{field}'" in printed) if field else "field '" not in printed


def test_the_installed_command_prints_one_line_for_a_broken_file(valid, tmp_path):
    folder = copy_results(valid, tmp_path / "run")
    lines = read_lines(folder)
    lines[2]["score"] = "high"
    (folder / "episodes.jsonl").write_text(dump(lines))
    result = subprocess.run([ROBOLAB, "analyze", str(folder)], capture_output=True, text=True, timeout=600, check=False)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    expected = (f"robolab: error: {folder / 'episodes.jsonl'} line 3, field 'score': is \"high\" (text), expected a "
                f"finite number. {LINE_FIX} (a later `robolab eval` with the same options runs that episode again); "
                "docs/results.md lists the fields")  # fmt: skip
    assert result.stderr.strip().splitlines() == [expected]
