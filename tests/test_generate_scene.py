"""`robolab generate scene`: the offline backend end to end, the HTTP path against a real OpenAI-compatible server
process with a feedback round, the grid baseline, contradictions, and the shared client's settings."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import yaml

from robolab_ms.catalog import load_catalog
from robolab_ms.errors import RoboLabError
from robolab_ms.generation.grid import grid_poses
from robolab_ms.generation.llm import ChatClient, EndpointSettings, endpoint_settings
from robolab_ms.generation.offline import OfflineSceneModel
from robolab_ms.generation.proposal import read_proposal
from robolab_ms.generation.scene import generate_scene
from robolab_ms.generation.settle import settle
from robolab_ms.generation.solver import REACH
from robolab_ms.scene import read_scene

ROBOLAB = [sys.executable, "-m", "robolab_ms.cli"]
PROMPT = (
    "A red mug to the left of a white bowl, a banana inside the bowl, and a stack of a red block, a blue block "
    "and a green block behind the bowl."
)
GOOD_ANSWER = {"objects": [{"name": "mug", "asset": "mug_red"}, {"name": "bowl", "asset": "bowl_white"},
                           {"name": "apple", "asset": "apple_red"}],
               "relations": [{"relation": "on_table", "object": "bowl", "x": 0.55, "y": 0.0},
                             {"relation": "left_of", "object": "mug", "reference": "bowl", "distance": 0.2},
                             {"relation": "inside", "object": "apple", "reference": "bowl"}]}  # fmt: skip


@pytest.fixture(scope="module")
def catalog():
    return load_catalog()


@pytest.mark.slow
def test_offline_scene_end_to_end(tmp_path, catalog):
    """The command writes a scene the loader and `robolab list` accept, that settles, with preview and transcript."""
    out = tmp_path / "content" / "scene_builders" / "mug_bowl_blocks.yaml"
    done = subprocess.run(
        [*ROBOLAB, "generate", "scene", PROMPT, "--out", str(out)], capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    assert "4 of 4 requested relations hold" in done.stdout
    spec = read_scene(out, catalog)
    assert {p.asset for p in spec.objects} == {
        "mug_red",
        "bowl_white",
        "banana",
        "block_red",
        "block_blue",
        "block_green",
    }
    assert spec.placement("banana").on == "bowl_white"
    assert spec.placement("block_green").on == "block_blue" and spec.placement("block_blue").on == "block_red"
    mug, bowl = spec.placement("mug_red"), spec.placement("bowl_white")
    assert mug.xy[1] > bowl.xy[1]  # left of = +y, seen from the robot
    assert settle(spec, {}, catalog).stable
    assert out.with_suffix(".png").stat().st_size > 10_000
    transcript = json.loads(out.with_name("mug_bowl_blocks.transcript.json").read_text())
    assert transcript["outcome"] == "accepted" and transcript["rounds"][0]["messages"][0]["content"] == PROMPT
    # a task on the generated scene is listed by `robolab list` with the folder as content
    tasks = tmp_path / "content" / "task_specs"
    tasks.mkdir()
    (tasks / "GeneratedMugProbe.yaml").write_text(
        "name: GeneratedMugProbe\nscene: mug_bowl_blocks\nepisode_seconds: 10\nattributes: []\n"
        "instructions: {default: pick up the mug, vague: pick it up, specific: pick up the red mug}\n"
        "success:\n  - {predicate: picked_up, objects: [mug_red]}\n"
    )
    listed = subprocess.run(
        [*ROBOLAB, "list", "--content", str(tmp_path / "content"), "--task", "GeneratedMugProbe"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert listed.returncode == 0, listed.stderr
    assert "mug_bowl_blocks" in listed.stdout


def test_http_endpoint_with_feedback_rounds(tmp_path, catalog, llm_server):
    """Against a real chat-completions server: a non-JSON answer and an unknown object go back as feedback; the
    third answer becomes the scene. The server's log shows what each request carried."""
    server = llm_server(
        [
            "Sure! Here is a nice scene with a mug.",
            {**GOOD_ANSWER, "objects": [*GOOD_ANSWER["objects"][:2], {"name": "apple", "asset": "aple"}]},
            GOOD_ANSWER,
        ]
    )
    client = ChatClient(EndpointSettings(server.base_url, "scripted-model", "test-key"), timeout=30)
    out = tmp_path / "http_scene.yaml"
    result = generate_scene(
        "a red mug left of a white bowl with an apple in it", out, client, render=False, catalog=catalog
    )
    assert result.accepted and result.rounds == 3
    requests = server.requests()
    assert len(requests) == 3 and all(r["model"] == "scripted-model" and r["bearer"] for r in requests)
    assert requests[0]["response_format"] == {"type": "json_object"}
    second, third = requests[1]["messages"], requests[2]["messages"]
    assert second[0]["role"] == "system" and "left of' means larger y" in second[0]["content"]
    assert second[2] == {"role": "assistant", "content": "Sure! Here is a nice scene with a mug."}
    assert "the answer is not JSON" in second[3]["content"]
    assert "unknown catalog object 'aple'" in third[-1]["content"] and "apple_red" in third[-1]["content"]
    spec = read_scene(out, catalog)
    assert spec.placement("apple").on == "bowl" and spec.placement("bowl").xy == (0.55, 0.0)
    # judged by the first answer that read as JSON (its 'inside' named the unknown object): both hold, and all
    # three relations of the accepted answer hold after settling
    assert result.satisfied() == len(result.requested) == 2
    assert result.settled.holds["answer"] == [True, True, True]
    transcript = json.loads(result.transcript.read_text())
    assert [len(r["feedback"]) > 0 for r in transcript["rounds"]] == [True, True, False]
    assert transcript["backend"].startswith("openai:scripted-model@")


def test_server_without_json_mode_and_fenced_answers(llm_server):
    """A server that refuses response_format is asked again without it; code fences around the JSON are removed."""
    server = llm_server(["```json\n" + json.dumps(GOOD_ANSWER) + "\n```"], json_mode=False)
    answer, raw = ChatClient(EndpointSettings(server.base_url, "m", "k")).ask_json(
        "system", [{"role": "user", "content": "a scene"}]
    )
    assert answer == GOOD_ANSWER and raw.startswith("```json")
    assert [r["response_format"] for r in server.requests()] == [{"type": "json_object"}, None]


def test_grid_baseline(tmp_path, catalog):
    """One answer, each object in its own cell with at most a quarter cell of jitter, nothing stacked or inside."""
    model = OfflineSceneModel(catalog)
    answer, _ = model.ask_json("[grid baseline]", [{"role": "user", "content": PROMPT}])
    assert answer["grid"] == {"rows": 2, "columns": 3}
    poses, problems = grid_poses(answer, catalog, seed=3)
    assert not problems and len(poses) == 6
    cell_x, cell_y = (REACH["x"][1] - REACH["x"][0]) / 2, (REACH["y"][1] - REACH["y"][0]) / 3
    for pose in poses:
        row, column = answer["cells"][pose.name]
        centre = (REACH["x"][0] + (row + 0.5) * cell_x, REACH["y"][0] + (column + 0.5) * cell_y)
        assert abs(pose.xy[0] - centre[0]) <= cell_x / 4 and abs(pose.xy[1] - centre[1]) <= cell_y / 4
    requested = read_proposal(model.ask_json("", [{"role": "user", "content": PROMPT}])[0], catalog).relations
    result = generate_scene(
        PROMPT, tmp_path / "grid_scene.yaml", model, method="grid", render=False, catalog=catalog, requested=requested
    )
    assert result.rounds == 1 and result.settled is not None
    assert len(result.objects) == 6 and result.collisions == 0
    spec = read_scene(tmp_path / "grid_scene.yaml", catalog)
    assert all(p.on is None for p in spec.objects)
    holds = dict(zip([r.kind for r in requested], result.settled.holds["requested"]))
    assert not holds["inside"] and not holds["stacked"]  # the baseline neither stacks nor fills containers


def test_contradictory_relations_go_back_as_feedback(tmp_path, catalog):
    """'a left of b' and 'b left of a' cannot both hold: the first round's feedback says so, the offline backend
    drops both, and the second round's scene is accepted."""
    proposal = read_proposal(
        {
            "objects": [{"name": "a", "asset": "apple_red"}, {"name": "b", "asset": "lemon"}],
            "relations": [
                {"relation": "left_of", "object": "a", "reference": "b"},
                {"relation": "left_of", "object": "b", "reference": "a"},
            ],
        },
        catalog,
    )
    assert len(proposal.problems) == 1 and "contradictory directions" in proposal.problems[0]
    assert "relations[0]" in proposal.problems[0] and "relations[1]" in proposal.problems[0]
    prompt = "A red apple left of a lemon. The lemon left of the apple."
    result = generate_scene(
        prompt, tmp_path / "contradiction.yaml", OfflineSceneModel(catalog), render=False, catalog=catalog
    )
    transcript = json.loads(result.transcript.read_text())
    assert "contradictory directions" in transcript["rounds"][0]["feedback"][0]
    assert result.accepted and result.rounds == 2
    assert len(yaml.safe_load((tmp_path / "contradiction.yaml").read_text())["objects"]) == 2


def test_supports_in_a_loop_and_misfits(catalog):
    proposal = read_proposal(
        {
            "objects": [
                {"name": "a", "asset": "block_red"},
                {"name": "b", "asset": "block_blue"},
                {"name": "bin", "asset": "bowl_white"},
            ],
            "relations": [
                {"relation": "on_top_of", "object": "a", "reference": "b"},
                {"relation": "on_top_of", "object": "b", "reference": "a"},
                {"relation": "inside", "object": "bin", "reference": "a"},
            ],
        },
        catalog,
    )
    assert any("loop" in problem for problem in proposal.problems)
    assert any("is not a container" in problem for problem in proposal.problems)


def test_endpoint_settings_name_what_is_missing(monkeypatch):
    for variable in (
        "ROBOLAB_LLM_BASE_URL",
        "ROBOLAB_LLM_MODEL",
        "ROBOLAB_LLM_API_KEY",
        "OPENAI_BASE_URL",
        "OPENAI_API_KEY",
    ):
        monkeypatch.delenv(variable, raising=False)
    with pytest.raises(RoboLabError, match="--model NAME .or ROBOLAB_LLM_MODEL.") as error:
        endpoint_settings("http://localhost:1/v1", None, "key")
    assert "--base-url" not in str(error.value)
    monkeypatch.setenv("ROBOLAB_LLM_MODEL", "m")
    monkeypatch.setenv("OPENAI_API_KEY", "k")
    assert endpoint_settings("http://h/v1", None, None) == EndpointSettings("http://h/v1", "m", "k")
