"""`robolab generate scene`: a prompt becomes a checked scene file, through a model, the solvers and physics.

Rounds: the model (an OpenAI-compatible endpoint or the offline backend) answers in the JSON format of
robolab_ms.generation.proposal; the answer is read (unknown objects, contradictory relations), the physical and
spatial solvers place the objects (robolab_ms.generation.solver), the scene loader checks the file, and the physics
settle drops everything (robolab_ms.generation.settle). Whatever fails goes back to the model as plain feedback,
for at most `rounds` rounds; relations the solver had to relax, or that do not hold after settling, are reported
too while rounds remain, and accepted in the last one. The transcript goes next to the output file, and a preview
image of the scene (DROID's external-left camera) next to it as well.

`method="grid"` is RoboLab's single-pass baseline (robolab_ms.generation.grid): one answer, no feedback.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robolab_ms.catalog import Catalog, load_catalog
from robolab_ms.errors import RoboLabError, SpecError, make_folder
from robolab_ms.generation.grid import grid_poses, grid_system_prompt
from robolab_ms.generation.llm import GenerationError, JsonModel, Transcript
from robolab_ms.generation.proposal import Relation, SceneProposal, read_proposal, system_prompt
from robolab_ms.generation.settle import SettleResult, settle
from robolab_ms.generation.solver import Pose, solve_layout
from robolab_ms.scene import (
    DEFAULT_TABLE_COLOR,
    DEFAULT_TABLE_SIZE,
    IDENTITY_QUAT,
    OVERLAP_TOLERANCE,
    SETTLE_CLEARANCE,
    ObjectPlacement,
    SceneSpec,
    footprint,
    read_scene,
    resting_height,
)
from robolab_ms.scene.outlines import outlines_overlap

METHODS = ("solver", "grid")
DEFAULT_ROUNDS = 4
OUTPUT_JITTER = {"xy": 0.01, "yaw_deg": 5}  # the generated scene's per-episode jitter
JITTERED_SETTLE_SEEDS = 3  # the physics check also settles the jittered layouts of episode seeds 0..2 (those validated)
PREVIEW_SIZE = (640, 360)


@dataclass
class SceneGeneration:
    """What a generation produced: the scene (when one was accepted), its checks and where its files are."""

    prompt: str
    method: str
    accepted: bool = False
    scene_file: Path | None = None
    preview: Path | None = None
    transcript: Path | None = None
    rounds: int = 0
    objects: dict[str, str] = field(default_factory=dict)  # final scene: name -> catalog name
    requested: list[Relation] = field(default_factory=list)  # the relations the first answer asked for
    settled: SettleResult | None = None
    relaxed: list[str] = field(default_factory=list)
    collisions: int = 0  # pairs of objects standing on the table whose outlines overlap at placement
    problems: list[str] = field(default_factory=list)  # what was still wrong when the rounds ran out
    seconds: float = 0.0

    def satisfied(self) -> int:
        """How many requested relations hold after settling."""
        return sum(self.settled.holds.get("requested", [])) if self.settled else 0

    def placed(self) -> int:
        """Objects in the final scene that did not fall off the table."""
        return len(self.objects) - (len(self.settled.fallen) if self.settled else 0)


def generate_scene(
    prompt: str,
    out: str | Path,
    model: JsonModel,
    method: str = "solver",
    objects: list[str] | None = None,
    rounds: int = DEFAULT_ROUNDS,
    seed: int = 0,
    render: bool = True,
    catalog: Catalog | None = None,
    requested: list[Relation] | None = None,
) -> SceneGeneration:
    """Generate a scene for `prompt` into `out` (a .yaml path; its stem becomes the scene's name). `objects`:
    catalog names the scene must contain. `requested`: the relations to judge the result by (default: those of
    the first answer; the grid baseline's answers have none). The transcript is saved whatever happens."""
    if method not in METHODS:
        raise RoboLabError(f"unknown method '{method}': use one of {', '.join(METHODS)}")
    if seed < 0:
        raise RoboLabError(f"--seed {seed}: give 0 or more")
    out = Path(out)
    if out.suffix != ".yaml":
        raise RoboLabError(f"--out {out}: a scene file ends in .yaml")
    catalog = catalog or load_catalog()
    for name in objects or []:
        if name not in catalog.names():
            from robolab_ms.errors import UnknownNameError

            raise UnknownNameError("catalog object (--objects)", name, catalog.names())
    started = time.perf_counter()
    result = SceneGeneration(prompt=prompt, method=method, requested=list(requested or []))
    transcript = Transcript(kind="scene", prompt=prompt, backend=model.name)
    try:
        if method == "grid":
            _grid_round(prompt, out, model, objects, seed, catalog, transcript, result)
        else:
            _solver_rounds(prompt, out, model, objects, rounds, seed, catalog, transcript, result)
        result.seconds = time.perf_counter() - started
        transcript.outcome = "accepted" if result.accepted else "failed: " + "; ".join(result.problems)
        if result.accepted and render:
            result.preview = render_preview(result.scene_file, out.with_suffix(".png"))
    finally:
        result.transcript = transcript.save(out)
    return result


def _user_prompt(prompt: str, objects: list[str] | None) -> str:
    return prompt + (f"\n\nThe scene must contain: {', '.join(objects)}" if objects else "")


def _solver_rounds(
    prompt: str,
    out: Path,
    model: JsonModel,
    objects: list[str] | None,
    rounds: int,
    seed: int,
    catalog: Catalog,
    transcript: Transcript,
    result: SceneGeneration,
) -> None:
    system = system_prompt(catalog, objects)
    transcript.system = system
    messages = [{"role": "user", "content": _user_prompt(prompt, objects)}]
    judge_first_answer = not result.requested
    for round_number in range(1, rounds + 1):
        last = round_number == rounds
        result.rounds = round_number
        try:
            answer, raw = model.ask_json(system, messages)
        except GenerationError as exc:
            answer, raw = None, exc.raw
            feedback = [str(exc)]
        if answer is not None:
            proposal = read_proposal(answer, catalog)
            if judge_first_answer:  # the first answer that reads as JSON says what was asked for
                result.requested = [r for r in proposal.relations if r.kind not in ("random_yaw", "anywhere")]
                judge_first_answer = False
            feedback = list(proposal.problems)
            missing = [name for name in objects or [] if name not in proposal.objects.values()]
            if missing:
                feedback.append(f'the scene must contain {", ".join(missing)}; add them to "objects"')
            if not feedback:
                feedback = _place_and_check(proposal, out, seed, catalog, result, final=last)
        transcript.record(messages, raw, feedback)
        if not feedback:
            result.accepted = True
            result.problems = []
            return
        result.problems = feedback
        messages = [
            *messages,
            {"role": "assistant", "content": raw},
            {"role": "user", "content": feedback_message(feedback)},
        ]


def feedback_message(feedback: list[str]) -> str:
    """The plain feedback the model gets for its last answer."""
    return (
        "Your last answer could not be used as it is:\n"
        + "\n".join(f"- {line}" for line in feedback)
        + "\nAnswer again with the whole corrected JSON object."
    )


def _place_and_check(
    proposal: SceneProposal, out: Path, seed: int, catalog: Catalog, result: SceneGeneration, final: bool
) -> list[str]:
    """Solve, write, load and settle one proposal; the feedback (empty when the scene is accepted)."""
    layout = solve_layout(proposal, catalog, seed)
    if layout.problems:
        return layout.problems
    relaxed = [f"{relation.where()} ({relation.describe()}) was relaxed: {why}" for relation, why in layout.relaxed]
    try:
        spec = write_scene(layout.poses, out, result.prompt, catalog, "solver")
    except SpecError as exc:
        return [f"the placed scene is not valid: {exc}"]
    judged = [relation for relation in proposal.relations if relation.kind not in ("random_yaw", "anywhere")]
    settled = settle(spec, {"requested": result.requested, "answer": judged}, catalog, JITTERED_SETTLE_SEEDS)
    feedback = []
    for name, drift in settled.moved().items():
        fell = " and fell off the table" if name in settled.fallen else ""
        support = spec.placement(name).on
        where = f" from '{support}'" if support else ""
        feedback.append(
            f"'{name}' moved {drift * 100:.1f} cm{where}{fell} in the physics check (at most 2 cm "
            "is allowed): give it a larger support, put it inside a container, or stand it on the table"
        )
    _record(result, proposal.objects, spec, settled, relaxed)
    if feedback or final:
        return feedback
    relaxed_indexes = {relation.index for relation, _ in layout.relaxed}
    not_holding = [
        f"{relation.where()} ({relation.describe()}) does not hold after the physics check"
        for relation, holds in zip(judged, settled.holds["answer"])
        if not holds and relation.index not in relaxed_indexes
    ]
    return relaxed + not_holding


def _record(
    result: SceneGeneration, objects: dict[str, str], spec: SceneSpec, settled: SettleResult, relaxed: list[str]
) -> None:
    result.objects = dict(objects)
    result.scene_file = spec.file
    result.settled = settled
    result.relaxed = relaxed
    result.collisions = placement_collisions(spec, load_catalog())


def _grid_round(
    prompt: str,
    out: Path,
    model: JsonModel,
    objects: list[str] | None,
    seed: int,
    catalog: Catalog,
    transcript: Transcript,
    result: SceneGeneration,
) -> None:
    system = grid_system_prompt(catalog, objects)
    transcript.system = system
    messages = [{"role": "user", "content": _user_prompt(prompt, objects)}]
    result.rounds = 1
    answer, raw = model.ask_json(system, messages)
    poses, problems = grid_poses(answer, catalog, seed)
    transcript.record(messages, raw, problems)
    if not poses:
        result.problems = problems or ["no object could be placed"]
        return
    try:
        spec = write_scene(poses, out, prompt, catalog, "grid")
        accepted = True
    except SpecError as exc:  # overlapping outlines: settle it anyway, as the baseline does, but write no file
        spec = spec_from_poses(poses, out.stem, prompt, catalog, out)
        out.unlink(missing_ok=True)
        problems = [*problems, f"the grid layout is not a valid scene file: {exc}"]
        accepted = False
    settled = settle(spec, {"requested": result.requested}, catalog)
    _record(result, {pose.name: pose.asset for pose in poses}, spec, settled, [])
    if not accepted:
        result.scene_file = None
    if not settled.stable:
        problems = [
            *problems,
            "unstable after settling: "
            + ", ".join(f"'{name}' moved {drift * 100:.1f} cm" for name, drift in settled.moved().items()),
        ]
    transcript.add_feedback(problems)
    result.problems = problems
    result.accepted = accepted and settled.stable


# ------------------------------------------------------------------------------------------------ scene files
def scene_data(poses: list[Pose], name: str, prompt: str) -> dict:
    """The scene file's content for the poses."""
    items = []
    for pose in poses:
        item: dict = {"name": pose.name, "asset": pose.asset, "xy": [round(pose.xy[0], 4), round(pose.xy[1], 4)]}
        yaw = math.degrees(math.remainder(pose.yaw, 2 * math.pi))
        if abs(yaw) > 1e-6:
            item["yaw_deg"] = round(yaw, 2)
        if pose.rests_on:
            item["rests_on"] = pose.rests_on
        items.append(item)
    description = " ".join(prompt.split())
    table = {"size": list(DEFAULT_TABLE_SIZE), "color": DEFAULT_TABLE_COLOR}
    return {"name": name, "description": description, "table": table, "jitter": dict(OUTPUT_JITTER), "objects": items}


def write_scene(poses: list[Pose], out: Path, prompt: str, catalog: Catalog, method: str) -> SceneSpec:
    """Write the scene file and read it back with the scene loader (SpecError when it refuses it)."""
    import yaml

    data = scene_data(poses, out.stem, prompt)
    make_folder(out.parent, "--out")
    header = (
        f"# Generated by `robolab generate scene` (method {method}); the prompt is the description.\n"
        "# Frame: x away from the robot, y to its left, z up; the table top is z = 0.\n"
    )
    body = yaml.safe_dump(
        {key: data[key] for key in ("name", "description")}, sort_keys=False, width=120, allow_unicode=True
    )
    lines = [
        f"{key}: " + yaml.safe_dump(data[key], default_flow_style=True, sort_keys=False).strip()
        for key in ("table", "jitter")
    ]
    lines.append("objects:")
    for item in data["objects"]:
        lines.append("  - " + yaml.safe_dump(item, default_flow_style=True, sort_keys=False, width=200).strip())
    out.write_text(header + body + "\n".join(lines) + "\n", encoding="utf-8")
    return read_scene(out, catalog)


def spec_from_poses(poses: list[Pose], name: str, prompt: str, catalog: Catalog, file: Path) -> SceneSpec:
    """A SceneSpec of table-standing objects without the loader's layout checks (for the grid baseline, whose
    outlines may overlap): each object resting upright on the table, SETTLE_CLEARANCE above it."""
    placements = tuple(
        ObjectPlacement(
            pose.name,
            pose.asset,
            pose.xy,
            pose.yaw,
            IDENTITY_QUAT,
            z=resting_height(catalog[pose.asset].points, IDENTITY_QUAT) + SETTLE_CLEARANCE,
        )
        for pose in poses
    )
    return SceneSpec(
        name=name,
        description=prompt,
        file=file,
        objects=placements,
        table_size=DEFAULT_TABLE_SIZE,
        table_rgba=(0.45, 0.3, 0.18, 1.0),
        jitter_xy=0.0,
        jitter_yaw=0.0,
    )


def placement_collisions(spec: SceneSpec, catalog: Catalog) -> int:
    """Pairs of objects standing on the table whose outlines overlap (deeper than the loader's tolerance) as placed."""
    standing = [placement for placement in spec.objects if placement.on is None]
    outlines = [footprint(catalog[placement.asset], placement) for placement in standing]
    count = 0
    for i in range(len(standing)):
        for j in range(i):
            if outlines_overlap(outlines[i], outlines[j]) > OVERLAP_TOLERANCE:
                count += 1
    return count


# ------------------------------------------------------------------------------------------------ preview image
PROBE_TASK = """name: {name}
scene: {scene}
episode_seconds: 1
attributes: []
instructions: {{default: look, vague: look, specific: look}}
success:
  - {{predicate: picked_up, objects: [{obj}]}}
"""


def render_preview(scene_file: Path, png: Path) -> Path:
    """DROID's external-left camera view of the scene at its nominal layout (seed 0, robot at home), as PNG."""
    import shutil

    import gymnasium as gym
    from PIL import Image

    import robolab_ms.envs  # noqa: F401  (registers the environments)
    from robolab_ms.envs import register_task_file

    spec = read_scene(scene_file)
    with tempfile.TemporaryDirectory(prefix="robolab_preview_") as folder:
        shutil.copy(scene_file, Path(folder) / scene_file.name)
        name = "Preview" + "".join(part.title() for part in spec.name.split("_") if part)
        task = Path(folder) / f"{name}.yaml"
        task.write_text(PROBE_TASK.format(name=name, scene=spec.name, obj=spec.objects[0].name), encoding="utf-8")
        env = gym.make(
            register_task_file(task, replace=True),
            task=str(task),
            obs_mode="rgb",
            cameras=("external_left",),
            camera_width=PREVIEW_SIZE[0],
            camera_height=PREVIEW_SIZE[1],
        )
        try:
            obs, _ = env.reset(seed=0)
            rgb = obs["sensor_data"]["external_left"]["rgb"][0].cpu().numpy().astype(np.uint8)
        finally:
            env.close()
    Image.fromarray(rgb).save(png, optimize=True)
    return png
