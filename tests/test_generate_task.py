"""`robolab generate task`: the offline backend end to end on a generated scene (list and eval of the result), the
HTTP path with feedback rounds against a real OpenAI-compatible server process (a schema error, a judge's
rejection), the rules judge on hand-written and mismatched conditions, and the offline reading of RoboLab's
instructions."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from robolab_ms.catalog import load_catalog
from robolab_ms.errors import RoboLabError
from robolab_ms.generation.judge import ALIGNED, MISALIGNED, UNSURE, ModelJudge, RulesJudge
from robolab_ms.generation.llm import ChatClient, EndpointSettings
from robolab_ms.generation.offline_task import OfflineTaskModel
from robolab_ms.generation.task import generate_task
from robolab_ms.scene import load_scene
from robolab_ms.tasks.spec import load_task, read_task

ROBOLAB = [sys.executable, "-m", "robolab_ms.cli"]
SCENE = "rubiks_cube_banana_bowl"  # a Rubik's cube, a banana and a red bowl (shipped)
GOOD = {"episode_seconds": 40, "attributes": ["semantics"],
        "instructions": {"default": "Put the banana in the bowl.", "vague": "Put the fruit away.",
                         "specific": "Pick up the yellow banana and place it inside the red bowl, then let go of it."},
        "success": [{"predicate": "in_container", "objects": ["banana"], "container": "bowl",
                     "require_contact_with": True, "require_gripper_detached": True}]}  # fmt: skip


@pytest.fixture(scope="module")
def catalog():
    return load_catalog()


def _write_task(folder: Path, name: str, instruction: str, condition: dict, scene: str = SCENE) -> Path:
    data = {
        "name": name,
        "scene": scene,
        "episode_seconds": 30,
        "attributes": [],
        "instructions": {"default": instruction, "vague": instruction, "specific": instruction},
        "success": [condition],
    }
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


@pytest.mark.slow
def test_offline_task_end_to_end_on_a_generated_scene(tmp_path):
    """A generated scene, then a generated task on it in the same content folder: the task passes validation, is
    listed by `robolab list --content` and solved by the oracle through `robolab eval`."""
    content = tmp_path / "content"
    scene_file = content / "scene_builders" / "gen_mug_bowl.yaml"
    made = subprocess.run(
        [
            *ROBOLAB,
            "generate",
            "scene",
            "A red mug to the left of a white bowl, and a banana in front of the mug.",
            "--out",
            str(scene_file),
            "--no-preview",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert made.returncode == 0, made.stderr
    out = content / "task_specs" / "GenBananaInWhiteBowl.yaml"
    done = subprocess.run(
        [
            *ROBOLAB,
            "generate",
            "task",
            "gen_mug_bowl",
            "put the banana in the white bowl",
            "--content",
            str(content),
            "--out",
            str(out),
            "--seeds",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "judge (rules): aligned" in done.stdout and "oracle 100%" in done.stdout
    data = yaml.safe_load(out.read_text())
    assert data["scene"] == "gen_mug_bowl"  # found by name from the content folder
    assert data["instructions"]["default"] == "Put the banana in the white bowl."
    assert data["success"][0]["predicate"] == "in_container" and data["success"][0]["objects"] == ["banana"]
    assert data["success"][0]["container"] == "bowl_white"
    assert "white bowl" in data["instructions"]["specific"] and data["attributes"]
    transcript = json.loads(out.with_name("GenBananaInWhiteBowl.transcript.json").read_text())
    assert transcript["kind"] == "task" and transcript["outcome"] == "accepted"
    assert transcript["rounds"][-1]["checks"]["validate"]["passed"] is True
    listed = subprocess.run(
        [*ROBOLAB, "list", "--content", str(content), "--task", "GenBananaInWhiteBowl"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert listed.returncode == 0, listed.stderr
    assert "GenBananaInWhiteBowl" in listed.stdout
    results = tmp_path / "eval"
    evaluated = subprocess.run(
        [
            *ROBOLAB,
            "eval",
            "--content",
            str(content),
            "--task",
            "GenBananaInWhiteBowl",
            "--policy",
            "oracle",
            "--episodes",
            "1",
            "--out",
            str(results),
            "--quiet",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert evaluated.returncode == 0, evaluated.stderr
    episodes = [json.loads(line) for line in (results / "episodes.jsonl").read_text().splitlines()]
    assert len(episodes) == 1 and episodes[0]["success"] is True


def test_http_endpoint_with_a_schema_error_then_validation(tmp_path, catalog, llm_server):
    """Against a real chat-completions server: an unknown predicate goes back with the loader's own error, the
    second answer passes, the model judges it aligned, and validation (1 seed) proves it."""
    bad = {**GOOD, "success": [{"predicate": "in_bowl", "objects": ["banana"], "container": "bowl"}]}
    server = llm_server([bad, GOOD, {"aligned": True, "problems": []}])
    client = ChatClient(EndpointSettings(server.base_url, "scripted-model", "test-key"), timeout=30)
    out = tmp_path / "task_specs" / "HttpBananaInBowl.yaml"
    result = generate_task(
        SCENE, "Put the banana in the bowl", out, client, ModelJudge(client, catalog), seeds=1, catalog=catalog
    )
    assert result.accepted and result.rounds == 2, result.problems
    requests = server.requests()
    assert len(requests) == 3 and all(r["model"] == "scripted-model" for r in requests)
    system, first_user = requests[0]["messages"][0]["content"], requests[0]["messages"][1]["content"]
    assert "in_container(container" in system and "FIRST condition" in system
    assert (
        first_user.startswith("Instruction: Put the banana in the bowl")
        and "- banana: curved_banana_scan" in first_user
    )
    feedback = requests[1]["messages"][-1]["content"]
    assert "field 'success[0].predicate': 'in_bowl' is not a known predicate" in feedback
    assert str(tmp_path) not in feedback  # the loader's error without our temporary path
    judge_request = requests[2]["messages"]
    assert "Decide whether the condition matches the instruction" in judge_request[0]["content"]
    assert "Instruction: Put the banana in the bowl." in judge_request[1]["content"]
    spec = read_task(out)
    assert spec.success[0].predicate == "in_container" and spec.scene.name == SCENE
    assert result.validation.passed and result.validation.oracle_success == 1.0
    transcript = json.loads(result.transcript.read_text())
    assert [bool(r["feedback"]) for r in transcript["rounds"]] == [True, False]
    assert transcript["rounds"][1]["checks"]["judge"]["verdict"] == ALIGNED
    assert transcript["rounds"][1]["checks"]["judge_conversation"]["answer"]


def test_judge_rejection_goes_back_as_feedback(tmp_path, catalog, llm_server):
    """The model writes left_of for 'right of'; the LLM judge rejects it, its reason reaches the model, and the
    corrected answer is accepted (validation skipped with seeds=0)."""
    wrong = {
        **GOOD,
        "attributes": ["spatial"],
        "success": [
            {"predicate": "left_of", "objects": ["banana"], "reference": "bowl", "require_gripper_detached": True}
        ],
    }
    right = {**wrong, "success": [{**wrong["success"][0], "predicate": "right_of"}]}
    reason = "the instruction says right of the bowl, the condition uses left_of"
    server = llm_server([wrong, {"aligned": False, "problems": [reason]}, right, {"aligned": True, "problems": []}])
    client = ChatClient(EndpointSettings(server.base_url, "m", "k"), timeout=30)
    out = tmp_path / "BananaRightOfBowl.yaml"
    result = generate_task(
        SCENE,
        "Put the banana to the right of the bowl",
        out,
        client,
        ModelJudge(client, catalog),
        seeds=0,
        catalog=catalog,
    )
    assert result.accepted and result.rounds == 2
    assert result.first_judgement.verdict == MISALIGNED and result.judgement.verdict == ALIGNED
    generator_round_two = server.requests()[2]["messages"]
    assert reason in generator_round_two[-1]["content"] and "the judge" in generator_round_two[-1]["content"]
    assert read_task(out).success[0].predicate == "right_of"
    # the rules judge rejects the same wrong answer by itself
    (tmp_path / "wrong").mkdir()
    wrong_file = _write_task(
        tmp_path / "wrong", "BananaLeftWrong", "Put the banana to the right of the bowl", wrong["success"][0]
    )
    verdict = RulesJudge(catalog).judge("Put the banana to the right of the bowl", read_task(wrong_file))
    assert verdict.verdict == MISALIGNED and "right of" in verdict.problems[0] and "right_of" in verdict.problems[0]


def test_rules_judge_on_mismatched_conditions(tmp_path, catalog):
    """Wrong object, wrong colour, wrong count, wrong container, an order the instruction does not ask for: each
    rejected with a reason naming it; the hand-written conditions of the same tasks accepted."""
    judge = RulesJudge(catalog)
    for task in (
        "RedItemsInBin",
        "BananasInBinThreeTotal",
        "RubiksCubeThenBanana",
        "ToolOrganization",
        "FruitsMovingOrangeOrLime",
        "WhiteMugInCenterOfTable",
        "StackYellowOnRed",
    ):
        spec = load_task(task)
        assert judge.judge(spec.instructions["default"], spec).verdict == ALIGNED, task
    cases = [
        (
            "Put the banana in the bowl.",
            {"predicate": "in_container", "objects": ["rubiks_cube"], "container": "bowl"},
            SCENE,
            "names 'the banana'",
        ),
        (
            "Put the red mug in the grey bin.",
            {"predicate": "in_container", "objects": ["banana"], "container": "grey_bin"},
            "rubiks_cube_banana_bowl_mug_bin",
            "banana",
        ),
        (
            "Put the white mugs in the grey bin.",
            {"predicate": "in_container", "objects": ["mug"], "container": "grey_bin"},
            "mugs2_bananas2_ketchup_rubiks3_bin",
            "mug_01",
        ),
        (
            "Put the Rubik's cube in the bowl.",
            {"predicate": "in_container", "objects": ["rubiks_cube"], "container": "grey_bin"},
            "rubiks_cube_banana_bowl_mug_bin",
            "grey_bin",
        ),
        (
            "Put the Rubik's cube and the banana in the bowl.",
            {"predicate": "placed_in_container_in_order", "objects": ["rubiks_cube", "banana"], "container": "bowl"},
            SCENE,
            "order",
        ),
        ("Pick up the banana.", {"predicate": "upright", "objects": ["banana"]}, SCENE, "picked_up"),
    ]
    for number, (instruction, condition, scene, expected) in enumerate(cases):
        path = _write_task(tmp_path, f"Mismatch{number}", instruction, condition, scene)
        verdict = judge.judge(instruction, read_task(path))
        assert verdict.verdict == MISALIGNED, (instruction, verdict)
        assert any(expected in problem for problem in verdict.problems), (instruction, verdict.problems)
    unreadable = _write_task(tmp_path, "Unreadable", "Dance.", {"predicate": "picked_up", "objects": ["banana"]})
    assert judge.judge("Dance.", read_task(unreadable)).verdict == UNSURE


def test_offline_backend_reads_robolab_instructions(catalog):
    """RoboLab's own instructions on its scenes give the hand-written conditions: predicate, objects (and `k`)
    and the container or reference."""
    for task in (
        "BananaThenRubiksCube",
        "ToolOrganization",
        "BananasInBinThreeTotal",
        "BigPumpkinInBin",
        "MustardInLeftBin",
        "StackYellowOnRed",
        "WhiteMugInCenterOfTable",
        "PhoneOrRemoteInBin",
        "ReorientRedMug",
        "KeyboardOutOfBin",
        "GrabABagel",
        "RubiksCubeBehindBowl",
        "YellowAndWhiteObjectsInBin",
    ):
        spec = load_task(task)
        answer = OfflineTaskModel(catalog, spec.scene).answer(spec.instructions["default"])
        made, gold = answer["success"][0], spec.success[0]
        objects = made.get("objects") or [o for members in made["groups"].values() for o in members]
        assert made["predicate"] == gold.predicate, task
        assert sorted(objects) == sorted(gold.objects), task
        assert made.get("logical", "all") == gold.logical and made.get("k", 1) == gold.k, task
        for key in ("container", "reference"):
            if key in made and key in gold.references:
                assert made[key] == gold.references[key], task
        if "groups" in made:
            assert made["groups"] == gold.params["groups"], task
        assert set(answer["instructions"]) == {"default", "vague", "specific"}


def test_no_file_when_every_round_fails(tmp_path, catalog):
    """An instruction the offline backend cannot read fails every round: no task file, the transcript says why."""
    out = tmp_path / "task_specs" / "Dance.yaml"
    done = subprocess.run(
        [*ROBOLAB, "generate", "task", SCENE, "Dance with the robot", "--out", str(out), "--rounds", "2"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 1 and "no action it knows" in done.stderr
    assert not out.exists()
    transcript = json.loads(out.with_name("Dance.transcript.json").read_text())
    assert len(transcript["rounds"]) == 2 and transcript["outcome"].startswith("failed")
    with pytest.raises(RoboLabError, match="already exists"):
        generate_task(
            SCENE,
            "Put the banana in the bowl",
            tmp_path / "BananaInBowl.yaml",
            OfflineTaskModel(catalog, load_scene(SCENE)),
            RulesJudge(catalog),
            seeds=0,
            catalog=catalog,
        )


def test_offline_feedback_answers_like_an_author():
    """Knocked into place in some seeds -> require_picked_up; holding without the robot (solved at reset, random
    policy in every seed) -> unchanged; the oracle out of time -> a longer episode; contact unmet -> flag dropped."""
    from robolab_ms.generation.offline_task import apply_task_feedback

    answer = {"episode_seconds": 40, "success": [dict(GOOD["success"][0])]}
    knocked = apply_task_feedback(answer, "- robolab validate (3 seed(s)): random policy succeeds 33% (max 10%)")
    assert knocked["success"][0]["require_picked_up"] is True and answer["success"][0].get("require_picked_up") is None
    for already in (
        "random policy succeeds 100% (max 10%)",
        "solved at reset in 3 seed(s); random policy succeeds 67% (max 10%)",
    ):
        assert apply_task_feedback(answer, already) == answer
    slow = apply_task_feedback(answer, "why the oracle failed: seed 0: ran out of time (750 steps): banana placed")
    assert slow["episode_seconds"] == 60
    loose = apply_task_feedback(answer, "banana placed, but not touching bowl (require_contact_with) at the end")
    assert "require_contact_with" not in loose["success"][0] and loose["success"][0]["require_gripper_detached"]


def test_scene_given_as_a_file_elsewhere(tmp_path, catalog):
    """A scene file the task's folder cannot find by name is written as a path relative to the task file, and the
    task loads from there (validation skipped: seeds=0)."""
    scenes = tmp_path / "elsewhere"
    scenes.mkdir()
    scene_file = scenes / "my_banana_bowl.yaml"
    scene_file.write_text(load_scene(SCENE).file.read_text().replace(f"name: {SCENE}", "name: my_banana_bowl"))
    out = tmp_path / "tasks" / "MyBananaInBowl.yaml"
    result = generate_task(
        str(scene_file),
        "put the banana in the red bowl",
        out,
        OfflineTaskModel(catalog, load_scene(SCENE)),
        RulesJudge(catalog),
        seeds=0,
        catalog=catalog,
    )
    assert result.accepted and result.judgement.verdict == ALIGNED
    assert yaml.safe_load(out.read_text())["scene"] == "../elsewhere/my_banana_bowl.yaml"
    spec = read_task(out)
    assert spec.scene.name == "my_banana_bowl" and spec.success[0].references["container"] == "bowl"
    assert "not validated (--seeds 0)" in out.read_text()
