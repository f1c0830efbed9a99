"""Every `robolab` command with its main options on small real inputs: one task and several, one policy and two,
with and without --vary, --record, --video and --workers 2, and results folders of an earlier version and partial
ones. Each case must end with exit 0 (1 where the command reports a failed check) or exit 2 with a one-line error,
never a traceback. Commands run in this process through `robolab_ms.cli.main` (an exception escaping it is the
traceback a user would see); the policy server and a closed stdout pipe run as real processes."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest
import trimesh

from robolab_ms.analysis.synthetic import LIGHT_SPACE, light_dependent_success, write_synthetic_run
from robolab_ms.cli import build_parser, main
from robolab_ms.content import CACHE_ENV

ROBOLAB = str(Path(sys.executable).with_name("robolab"))
TESTS = Path(__file__).parent
ONE = "BananaInBowl"
TWO = ("BananaInBowl", "RubiksCubeLeftOfBowl")
SHORT = ("--episodes", "1", "--max-steps", "3", "--quiet")
# results folders shared by the cases: `robolab eval` options of each (SHORT and --out added)
EVALS = {
    "random_one": ("--policy", "random", "--task", ONE),
    "random_two": ("--policy", "random", "--task", *TWO),
    "hold_two": ("--policy", "hold", "--task", *TWO),
    "oracle_vary": ("--policy", "oracle", "--task", *TWO, "--vary", "lighting,objects", "--episodes", "2"),
    "random_vary": ("--policy", "random", "--task", *TWO, "--vary", "lighting,objects", "--episodes", "2"),
    "recorded": ("--policy", "random", "--task", ONE, "--record-images", "--video", "--save-actions"),
    "workers": ("--policy", "random", "--task", *TWO, "--workers", "2", "--record", "--vary", "lighting"),
}  # fmt: skip
# the fields of a result line in the first version of the results format (git history of eval/results.py)
FIRST_VERSION_FIELDS = ("task", "instruction_variant", "instruction", "robot", "policy", "seed", "success", "score",
                        "progress", "steps", "max_steps", "success_step", "wall_seconds", "error", "events", "metrics",
                        "version")  # fmt: skip


@dataclass
class Ran:
    code: int
    printed: str  # stdout and stderr


def run_cli(*args: object) -> Ran:
    """`robolab ARGS` in this process, its output captured. An exception escaping the command fails the test."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(arg) for arg in args])
        except SystemExit as exit:  # argparse: --help, usage errors
            code = exit.code
    return Ran(code, out.getvalue() + err.getvalue())


def assert_clean(ran: Ran, codes: frozenset[int]) -> None:
    assert ran.code in codes, ran.printed[-3000:]
    assert "Traceback" not in ran.printed, ran.printed[-3000:]
    if ran.code == 2:  # one message on one line: ours (robolab: error:) or argparse's (robolab CMD: error:)
        errors = [line for line in ran.printed.splitlines() if line.startswith("robolab") and " error: " in line]
        assert len(errors) == 1, ran.printed[-3000:]


@pytest.fixture(scope="module")
def workspace(tmp_path_factory, request) -> Path:
    """A folder for the shared inputs, and a coacd cache of its own."""
    folder = tmp_path_factory.mktemp("matrix")
    patch = pytest.MonkeyPatch()
    patch.setenv(CACHE_ENV, str(folder / "cache"))
    request.addfinalizer(patch.undo)
    return folder


@pytest.fixture(scope="module")
def folders(workspace) -> dict[str, Path]:
    """The results folders of EVALS (each run once; its outcome is a case of its own), one of the first version of
    the results format, a partial one (no manifest, no tables, a half-written last line), one with a broken line,
    a synthetic one large enough for a sensitivity fit, and a recording with a damaged .json."""
    made: dict[str, Path] = {}
    for name, options in EVALS.items():
        made[name] = workspace / name
        args = ("eval", *SHORT, *options, "--out", made[name])
        if "--workers" in options:  # the installed command: what its worker processes print is checked too
            done = subprocess.run([ROBOLAB, *map(str, args)], capture_output=True, text=True, timeout=600, check=False)
            made[f"{name}:ran"] = Ran(done.returncode, done.stdout + done.stderr)  # type: ignore[assignment]
        else:
            made[f"{name}:ran"] = run_cli(*args)  # type: ignore[assignment]
    lines = [json.loads(line) for line in (made["random_two"] / "episodes.jsonl").read_text().splitlines()]
    earlier = workspace / "earlier_version"
    earlier.mkdir()
    (earlier / "episodes.jsonl").write_text("".join(
        json.dumps({**{k: v for k, v in line.items() if k in FIRST_VERSION_FIELDS}, "robot": "panda", "metrics": {}})
        + "\n" for line in lines))  # fmt: skip
    partial = workspace / "partial"
    partial.mkdir()
    text = "".join(json.dumps(line) + "\n" for line in lines)
    (partial / "episodes.jsonl").write_text(text + text.splitlines()[0][:90])
    broken = workspace / "broken"
    shutil.copytree(made["random_two"], broken, ignore=shutil.ignore_patterns(".writer.lock"))
    (broken / "episodes.jsonl").write_text("".join(json.dumps({**line, "score": "high"} if i == 1 else line) + "\n"
                                                   for i, line in enumerate(lines)))  # fmt: skip
    synthetic = write_synthetic_run(workspace / "synthetic", "model", list(TWO), 15, light_dependent_success,
                                    params=LIGHT_SPACE)  # fmt: skip
    damaged = workspace / "damaged_recording"
    shutil.copytree(made["recorded"], damaged, ignore=shutil.ignore_patterns(".writer.lock"))
    next((damaged / "recordings").rglob("*.json")).write_text('{"robolab": {"task": "BananaInBowl", "seed": ')
    usd = workspace / "usd" / "banana_bowl.usda"
    made[":usd"] = run_cli("scene", "export", "banana_bowl", "--usd", usd)  # type: ignore[assignment]
    (workspace / "not_usd.usda").write_text("#usda 1.0\n(\n  this is not USD\n")
    trimesh.creation.box([0.05, 0.04, 0.08]).export(workspace / "parcel.obj")
    shutil.copy(TESTS.parent / "assets" / "catalog.yaml", workspace / "catalog.yaml")
    (workspace / "real.csv").write_text("policy,success,episodes\nrandom,0.1,20\nhold,0,20\n")
    (workspace / "real_bad.csv").write_text("policy,success\nrandom,high\n")
    (workspace / "a_file").write_text("not a folder\n")
    made.update(earlier_version=earlier, partial=partial, broken=broken, synthetic=synthetic, damaged=damaged,
                usd=usd)  # fmt: skip
    return made


class _Places(dict):
    """Names in case arguments: a results folder by name, `copy_NAME` (a fresh copy of it in the case's folder),
    `tmp` (the case's folder) and the workspace's inputs."""

    def __init__(self, folders: dict[str, Path], workspace: Path, tmp: Path) -> None:
        super().__init__({name: str(path) for name, path in folders.items() if isinstance(path, Path)})
        self.update(tmp=str(tmp), ws=str(workspace), fixtures=str(TESTS / "fixtures"))
        self.folders, self.tmp = folders, tmp

    def __missing__(self, key: str) -> str:
        if key.startswith("copy_"):
            target = self.tmp / key
            shutil.copytree(self.folders[key.removeprefix("copy_")], target,
                            ignore=shutil.ignore_patterns(".writer.lock"))  # fmt: skip
            self[key] = str(target)
            return self[key]
        raise KeyError(key)


@dataclass(frozen=True)
class Case:
    id: str
    args: tuple[str, ...]
    codes: frozenset[int] = frozenset({0})
    check: Callable[[Path, str], None] | None = None  # (the case's folder, what was printed)


def ok(id: str, *args: str, check: Callable[[Path, str], None] | None = None) -> Case:
    return Case(id, args, frozenset({0}), check)


def error(id: str, *args: str, says: str = "") -> Case:
    """A case that must stop with exit 2 and a message containing `says`."""

    def check(tmp: Path, printed: str) -> None:
        assert says in printed, printed

    return Case(id, args, frozenset({2}), check)


def checked(id: str, *args: str) -> Case:
    """A command that reports a failed check with exit 1 (validate, render-check, replay, generate)."""
    return Case(id, args, frozenset({0, 1}))


def _episodes(folder: str, count: int) -> Callable[[Path, str], None]:
    def check(tmp: Path, printed: str) -> None:
        path = Path(folder.format(tmp=tmp)) / "episodes.jsonl"
        assert len([line for line in path.read_text().splitlines() if line.endswith("}")]) == count

    return check


def _files(*names: str) -> Callable[[Path, str], None]:
    def check(tmp: Path, printed: str) -> None:
        for name in names:
            assert (tmp / name).exists(), name

    return check


def _partial_parameter_plot(tmp: Path, printed: str) -> None:
    """The object of one task's scene is drawn in half the episodes: its panel says so (the NaN fix)."""
    svg = (tmp / "analysis" / "plots" / "success_by_parameter.svg").read_text()
    svg += "".join(path.read_text() for path in (tmp / "analysis" / "plots").glob("success_by_parameter_*.svg"))
    assert "obj_rubiks_cube_dx" in svg and "4 of 8 episodes" in svg


def _first_version_tables(tmp: Path, printed: str) -> None:
    overall = pd.read_csv(tmp / "analysis" / "overall.csv")
    assert overall["episodes"].sum() == 4 and set(pd.read_csv(tmp / "analysis" / "by_robot.csv")["robot"]) == {
        "droid", "panda"}  # fmt: skip


def _partial_tables(tmp: Path, printed: str) -> None:
    assert pd.read_csv(tmp / "analysis" / "overall.csv")["episodes"].sum() == 2  # the half-written line left out


OUT = ("--out", "{tmp}/out")
CASES = [
    # list and suites
    ok("list", "list"),
    ok("list two tasks", "list", "--task", *TWO),
    ok("list filters", "list", "--tag", "spatial", "--difficulty", "simple"),
    ok("list summary csv", "list", "--summary", "--format", "csv", "--task", *TWO),
    ok("list summary markdown", "list", "--summary", "--format", "markdown", "--task", ONE),
    error("list format without summary", "list", "--format", "csv", says="add --summary"),
    error("list unknown task", "list", "--task", "BananaInBowel", says="Did you mean 'BananaInBowl'"),
    error("list unknown tag", "list", "--task", *TWO, "--tag", "spatiall", says="unknown tag"),
    ok("suites", "suites"),
    # eval beyond the shared folders
    ok("eval policy name, panda, vague", "eval", *SHORT, "--policy", "hold", "--policy-name", "hold-v2", "--robot",
       "panda", "--instruction", "vague", "--task", ONE, *OUT, check=_episodes("{tmp}/out", 1)),
    ok("eval so100", "eval", *SHORT, "--robot", "so100", "--task", ONE, *OUT),
    ok("eval suite, two conditions", "eval", *SHORT, "--task", ONE, "--suite", "lighting:dim/red", *OUT,
       check=_files("out/suite.md", "out/dim/episodes.jsonl", "out/red/episodes.jsonl")),
    ok("eval adaptive", "eval", "--quiet", "--task", ONE, "--episodes-adaptive", "10", "--ci-width", "0.9",
       "--max-steps", "1", *OUT, check=_episodes("{tmp}/out", 10)),
    ok("eval replay policy", "eval", *SHORT, "--policy", "replay", "--replay-from", "{recorded}", "--task", ONE, *OUT),
    ok("eval task file", "eval", *SHORT, "--task", "{fixtures}/PredicateLab.yaml", *OUT),
    ok("eval into a folder of an earlier version", "eval", *SHORT, "--policy", "random", "--task", ONE, "--out",
       "{copy_earlier_version}", check=_episodes("{tmp}/copy_earlier_version", 3)),
    ok("eval resumes a partial folder", "eval", *SHORT, "--episodes", "2", "--policy", "random", "--task", *TWO,
       "--out", "{copy_partial}", check=_episodes("{tmp}/copy_partial", 4)),
    error("eval into a folder with a broken line", "eval", *SHORT, "--task", *TWO, "--out", "{copy_broken}",
          says="line 2, field 'score'"),
    error("eval other variations into a folder", "eval", *SHORT, "--task", ONE, "--vary", "lighting", "--out",
          "{copy_random_one}", says="give another --out"),
    error("eval no episodes", "eval", "--task", ONE, "--episodes", "0", says="--episodes"),
    error("eval no steps", "eval", "--task", ONE, "--max-steps", "0", says="--max-steps"),
    error("eval negative seed", "eval", "--task", ONE, "--seed", "-1", says="--seed"),
    error("eval unknown task", "eval", "--task", "BananaInBowel", says="Did you mean"),
    error("eval unknown axis", "eval", "--task", ONE, "--vary", "lightning", says="unknown axis"),
    error("eval no workers", "eval", "--task", ONE, "--workers", "0", says="--workers"),
    error("eval unknown instruction", "eval", "--task", ONE, "--instruction", "loud", says="--instruction"),
    error("eval interval width", "eval", "--task", ONE, "--ci-width", "2", says="--ci-width"),
    error("eval unknown suite", "eval", "--task", ONE, "--suite", "lightning", says="unknown suite"),
    error("eval no policy server", "eval", *SHORT, "--policy", "openpi", "--port", "1", "--task", ONE,
          "--reconnect-seconds", "1", *OUT, says="no openpi policy server"),
    error("eval policy module missing", "eval", "--policy", "no_such_module:make", "--task", ONE, says="cannot import"),
    error("eval replay without a folder", "eval", "--policy", "replay", "--task", ONE, says="--replay-from"),
    error("eval out is a file", "eval", *SHORT, "--task", ONE, "--out", "{ws}/a_file", says="is a file"),
    error("eval ray nothing there", "eval", *SHORT, "--task", ONE, "--ray", "127.0.0.1:1", *OUT,
          says="no Ray cluster answers"),
    error("eval no task", "eval", says="--task"),
    # validate
    checked("validate one task", "validate", "--task", ONE, "--seeds", "1", "--quiet", *OUT),
    checked("validate varied", "validate", "--task", ONE, "--seeds", "1", "--quiet", "--vary", "lighting", *OUT),
    error("validate no task", "validate", "--seeds", "1", says="--task"),
    error("validate no seeds", "validate", "--task", ONE, "--seeds", "0", says="--seeds"),
    error("validate out is a file", "validate", "--task", ONE, "--seeds", "1", "--out", "{ws}/a_file",
          says="is a file"),
    # analyze
    ok("analyze one folder", "analyze", "{random_one}"),
    ok("analyze two policies", "analyze", "{random_two}", "{hold_two}", "--out", "{tmp}/analysis",
       check=_files("analysis/by_task.csv", "analysis/plots/success_heatmap.png")),
    ok("analyze paired comparison", "analyze", "{random_two}", "{hold_two}", "--compare", "--resamples", "100"),
    ok("analyze varied, two policies, plots", "analyze", "{oracle_vary}", "{random_vary}", "--out", "{tmp}/analysis",
       check=_partial_parameter_plot),
    ok("analyze varied by all, filtered", "analyze", "{oracle_vary}", "{random_vary}", "--by", "all", "--where",
       "light_intensity>0", "--where", "task=BananaInBowl,RubiksCubeLeftOfBowl"),
    ok("analyze recorded and parallel runs", "analyze", "{recorded}", "{workers}", "--by", "task,run", "--no-plots",
       "--out", "{tmp}/analysis"),
    ok("analyze by nested fields", "analyze", "{random_two}", "{hold_two}", "--by", "policy_metadata,endpoint"),
    ok("analyze earlier version", "analyze", "{earlier_version}", "{random_two}", "--by", "robot", "--out",
       "{tmp}/analysis", check=_first_version_tables),
    ok("analyze partial folder", "analyze", "{partial}", "--out", "{tmp}/analysis", check=_partial_tables),
    error("analyze broken line", "analyze", "{broken}", says="line 2, field 'score'"),
    error("analyze unknown grouping", "analyze", "{random_two}", "--by", "taks", says="Did you mean"),
    error("analyze no bins", "analyze", "{random_two}", "--bins", "0", says="--bins"),
    error("analyze compare one policy", "analyze", "{random_two}", "--compare", says="exactly two policies"),
    error("analyze missing folder", "analyze", "{tmp}/nothing", says="no such folder"),
    error("analyze out is a file", "analyze", "{random_two}", "--out", "{ws}/a_file", says="is a file"),
    # sensitivity
    ok("sensitivity fit", "sensitivity", "{synthetic}", "--epochs", "2", "--samples", "100", "--out", "{tmp}/s",
       check=_files("s/sensitivity.csv", "s/sensitivity_marginals.png")),
    error("sensitivity two policies", "sensitivity", "{oracle_vary}", "{random_vary}", says="--policy"),
    error("sensitivity few episodes", "sensitivity", "{oracle_vary}", "{random_vary}", "--policy", "oracle",
          "--obs", "score"),
    error("sensitivity nothing varied", "sensitivity", "{earlier_version}", says="no drawn variation parameters"),
    error("sensitivity unknown parameter", "sensitivity", "{synthetic}", "--params", "light_intensty",
          says="Did you mean"),
    # leaderboard
    ok("leaderboard two policies", "leaderboard", "{random_two}", "{hold_two}", "--out", "{tmp}/site",
       check=_files("site/index.html", "site/leaderboard.md")),
    ok("leaderboard videos copied", "leaderboard", "{recorded}", "{random_two}", "--out", "{tmp}/site"),
    ok("leaderboard videos linked", "leaderboard", "{recorded}", "--videos", "link", "--out", "{tmp}/site"),
    ok("leaderboard real world", "leaderboard", "{random_two}", "{hold_two}", "--real-world", "{ws}/real.csv",
       "--out", "{tmp}/site", check=_files("site/sim_to_real.png")),
    ok("leaderboard earlier version and partial", "leaderboard", "{earlier_version}", "{partial}", "--out",
       "{tmp}/site"),
    error("leaderboard broken line", "leaderboard", "{broken}", "--out", "{tmp}/site", says="line 2"),
    error("leaderboard out not a site", "leaderboard", "{random_two}", "--out", "{copy_hold_two}", says="not empty"),
    error("leaderboard real world unreadable", "leaderboard", "{random_two}", "--real-world", "{ws}/real_bad.csv",
          "--out", "{tmp}/site", says="not a number"),
    # export and replay
    ok("export lerobot with videos", "export", "lerobot", "{recorded}", "{tmp}/dataset",
       check=_files("dataset/meta/info.json", "dataset/data/chunk-000/file-000.parquet")),
    ok("export lerobot one task, no videos", "export", "lerobot", "{recorded}", "{tmp}/dataset", "--task", ONE,
       "--no-videos"),
    error("export lerobot successes only", "export", "lerobot", "{recorded}", "{tmp}/dataset", "--success-only",
          says="no successful episode"),
    error("export lerobot no recordings", "export", "lerobot", "{random_two}", "{tmp}/dataset",
          says="no recordings"),
    error("export lerobot damaged recording", "export", "lerobot", "{damaged}", "{tmp}/dataset",
          says="cannot be read as JSON"),
    checked("replay a results folder", "replay", "{recorded}"),
    checked("replay a parallel run", "replay", "{workers}"),
    ok("export lerobot of a parallel run", "export", "lerobot", "{workers}", "{tmp}/dataset", "--no-videos"),
    error("replay nothing recorded", "replay", "{random_two}", says="no recordings"),
    # catalog
    ok("catalog list", "catalog", "list"),
    checked("catalog check", "catalog", "check", "--objects", "banana", "--no-render"),
    ok("catalog sheet", "catalog", "sheet", "--objects", "banana", "--tile", "32", "--out", "{tmp}/sheet.png",
       check=_files("sheet.png")),
    ok("catalog build", "catalog", "build", "--catalog", "{ws}/catalog.yaml", "--objects", "banana"),
    ok("catalog add", "catalog", "add", "{ws}/parcel.obj", "--name", "matrix_parcel", "--class", "box", "--content",
       "{tmp}/content", "--no-sheet"),
    error("catalog check unknown object", "catalog", "check", "--objects", "bananna", says="Did you mean"),
    error("catalog sheet tiny tiles", "catalog", "sheet", "--objects", "banana", "--tile", "0", "--out",
          "{tmp}/sheet.png", says="--tile"),
    error("catalog build unknown object", "catalog", "build", "--catalog", "{ws}/catalog.yaml", "--objects",
          "bananna", says="Did you mean"),
    error("catalog add missing mesh", "catalog", "add", "{tmp}/none.obj", "--name", "x", "--class", "box",
          "--content", "{tmp}/content", says="does not exist"),
    # scene
    ok("scene export", "scene", "export", "banana_bowl", "--usd", "{tmp}/scene.usda"),
    ok("scene import", "scene", "import", "{usd}", "--out", "{tmp}/imported.yaml", check=_files("imported.yaml")),
    error("scene export unknown scene", "scene", "export", "banana_bowll", "--usd", "{tmp}/x.usda",
          says="Did you mean"),
    error("scene import not USD", "scene", "import", "{ws}/not_usd.usda", "--out", "{tmp}/x.yaml",
          says="does not open as a USD stage"),
    # generate (offline backend)
    checked("generate scene", "generate", "scene", "a banana in a white bowl", "--out", "{tmp}/gen_banana.yaml",
            "--no-preview", "--rounds", "1"),
    checked("generate task", "generate", "task", "banana_bowl", "put the banana in the bowl", "--out",
            "{tmp}/GenBanana.yaml", "--seeds", "0"),
    error("generate scene no rounds", "generate", "scene", "a banana", "--out", "{tmp}/g.yaml", "--rounds", "0",
          says="--rounds"),
    error("generate scene without an endpoint", "generate", "scene", "a banana", "--out", "{tmp}/g.yaml", "--llm",
          "openai", says="--llm openai needs"),
    error("generate task negative seed", "generate", "task", "banana_bowl", "put the banana in the bowl", "--out",
          "{tmp}/G.yaml", "--seed", "-1", "--seeds", "1", says="--seed"),
    # render-check, serve's refusals, the parser
    checked("render-check one scene", "render-check", "--scene", "banana_bowl", "--width", "32", "--height", "18"),
    error("render-check no pixels", "render-check", "--scene", "banana_bowl", "--width", "0", says="--width"),
    error("serve a privileged policy", "serve", "--policy", "oracle", says="cannot be served"),
    error("serve a client", "serve", "--policy", "openpi", says="is a client"),
    error("no command", says="required"),
    error("unknown command", "evaluate", says="invalid choice"),
]  # fmt: skip


def _commands(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """Every command and subcommand of the parser (`catalog add`, ...)."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.append((*prefix, name))
                found += _commands(sub, (*prefix, name))
    return found


COMMANDS = _commands(build_parser())


@pytest.mark.parametrize("case", CASES, ids=[case.id for case in CASES])
def test_command(case, folders, workspace, tmp_path):
    places = _Places(folders, workspace, tmp_path)
    args = [arg.format_map(places) for arg in case.args]
    ran = run_cli(*args)
    assert_clean(ran, case.codes)
    if case.check is not None:
        case.check(tmp_path, ran.printed)


@pytest.mark.parametrize("name", list(EVALS))
def test_eval_shared_folder(name, folders):
    assert_clean(folders[f"{name}:ran"], frozenset({0}))
    episodes = (folders[name] / "episodes.jsonl").read_text().splitlines()
    options = EVALS[name]
    per_task = int(options[options.index("--episodes") + 1]) if "--episodes" in options else 1
    assert len(episodes) == (options.count(TWO[1]) + 1) * per_task
    if "--record" in options or "--record-images" in options:
        assert len(list((folders[name] / "recordings").rglob("*.h5"))) == len(episodes)
    if "--video" in options:
        assert len(list((folders[name] / "videos").rglob("*.mp4"))) == len(episodes)


def test_scene_export_shared_file(folders):
    assert_clean(folders[":usd"], frozenset({0}))


@pytest.mark.parametrize("command", COMMANDS, ids=[" ".join(command) for command in COMMANDS])
def test_help(command):
    ran = run_cli(*command, "--help")
    assert_clean(ran, frozenset({0}))
    assert f"usage: robolab {' '.join(command)}" in ran.printed


def test_every_command_has_a_case():
    covered = {tuple(case.args[:2]) for case in CASES} | {tuple(case.args[:1]) for case in CASES} | {("serve",)}
    missing = [" ".join(command) for command in COMMANDS if command not in covered]
    assert not missing, f"commands without a case in CASES: {missing}"


def test_serve_and_evaluate_against_it(folders, tmp_path):
    """A real `robolab serve` process: `eval --policy openpi` runs against it, a second server on its port is
    refused with one line."""
    from servers import free_port, robolab_serve

    port = str(free_port())
    server = robolab_serve("--policy", "random", "--port", port)
    try:
        ran = run_cli("eval", *SHORT, "--policy", "openpi", "--port", port, "--task", ONE, "--out", tmp_path / "out")
        assert_clean(ran, frozenset({0}))
        second = subprocess.run([ROBOLAB, "serve", "--policy", "random", "--port", port], capture_output=True,
                                text=True, timeout=300, check=False)  # fmt: skip
        assert_clean(Ran(second.returncode, second.stdout + second.stderr), frozenset({2}))
        assert "cannot listen" in second.stderr
    finally:
        server.stop()


@pytest.mark.parametrize("command", [("suites",), ("list", "--task", *TWO)], ids=["suites", "list"])
def test_reader_closing_the_pipe_ends_the_command_quietly(command):
    """`robolab suites | head -1`: the reader goes away before the output is written."""
    process = subprocess.Popen([ROBOLAB, *command], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    process.stdout.close()
    err = process.stderr.read().decode()
    assert process.wait(timeout=300) in (0, 1) and "Traceback" not in err and "BrokenPipeError" not in err, err
