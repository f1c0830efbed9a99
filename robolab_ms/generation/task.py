"""`robolab generate task`: an instruction on a scene becomes a checked task file, through a model and validation.

Rounds: the model (an OpenAI-compatible endpoint or the offline backend) answers with the task spec as JSON (our
task schema less `name` and `scene`, which come from the output file and the scene given). Each answer goes
through four checks, and the first that fails goes back to the model as plain feedback, for at most `rounds`
rounds:

1. schema: the task loader reads the answer as a task file (robolab_ms.tasks.spec), with its own errors;
2. solvable by the oracle: the first condition's predicate is one the oracle turns into pick-and-place jobs;
3. judge: the condition matches the instruction (an LLM judge, or the rules of robolab_ms.generation.judge);
4. `robolab validate` in this process (robolab_ms.eval.validate.validate_task) over `seeds` seeds: stable at
   rest, not solved at reset, not passed by the random policy, solved by the oracle.

A judge that is unsure (the rules cannot read the instruction) does not block: the task is then proven by
validation alone, and the transcript says so. Candidates are written to a temporary folder; only an accepted task
is written to `out`, so a content folder never holds a task that failed. The transcript goes next to `out`.
"""

from __future__ import annotations

import os
import re
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import yaml

from robolab_ms.catalog import Catalog, load_catalog
from robolab_ms.errors import RoboLabError, make_folder
from robolab_ms.generation.judge import ALIGNED, UNSURE, Judge, Judgement, ModelJudge, scene_listing
from robolab_ms.generation.llm import GenerationError, JsonModel, Transcript
from robolab_ms.generation.offline_task import INSTRUCTION_PREFIX, tidy
from robolab_ms.generation.proposal import FRAME
from robolab_ms.generation.scene import feedback_message
from robolab_ms.scene import SceneSpec, load_scene, read_scene, scene_files
from robolab_ms.tasks.predicates import PREDICATES
from robolab_ms.tasks.spec import AXIS_OF_ATTRIBUTE, INSTRUCTION_VARIANTS, TASK_KEYS, TaskSpec, read_task

DEFAULT_ROUNDS = 3
DEFAULT_SEEDS = 3
ATTRIBUTE_MEANINGS = {
    "color": "an object is picked out by its colour", "semantics": "by what it is (a category: fruit, tools)",
    "size": "by its size (the bigger pumpkin)", "conjunction": "several objects joined by and / or, or in sequence",
    "counting": "a number of objects (two of the mugs, make it three)", "spatial": "a place or side (left of, the "
    "left bin, the centre of the table)", "affordance": "a grasp the object's shape asks for (a handle, a rim)",
    "reorientation": "the object must be turned (stand it upright)", "stacking": "one object on another, a tower",
    "sorting": "a group of objects put away by kind or colour", "vague": "the default instruction itself is vague",
}  # fmt: skip


@dataclass
class TaskGeneration:
    """What a task generation produced: the task (when accepted), its checks and where its files are."""

    instruction: str
    scene: str
    accepted: bool = False
    task_file: Path | None = None
    transcript: Path | None = None
    rounds: int = 0
    stopped_at: str = ""  # the check the last round stopped at: answer, schema, solvable, judge, validate, accepted
    first_judgement: Judgement | None = None  # the judge's verdict on the first answer that reached it
    judgement: Judgement | None = None  # ... on the last one
    validation: Any = None  # the last TaskValidation row
    problems: list[str] = field(default_factory=list)
    seconds: float = 0.0
    validate_seconds: float = 0.0
    condition: dict[str, Any] | None = None  # the accepted (or last read) first success condition


def resolve_scene(scene: str | Path) -> SceneSpec:
    """A scene by name (shipped, or of a content folder) or by file path."""
    text = str(scene)
    if text.endswith((".yaml", ".yml")) or os.sep in text or "/" in text:
        path = Path(text).expanduser()
        if not path.is_file():
            raise RoboLabError(
                f"scene file '{scene}' does not exist. Give a scene name (robolab list shows the "
                "scenes) or the path of a scene file"
            )
        return read_scene(path.resolve())
    return load_scene(text)


def scene_field(scene: SceneSpec, out: Path) -> str:
    """What the task file's `scene:` says: the scene's name when the task loader finds this very scene by name from
    `out`'s folder (a content folder, or a scene next to it), else the scene file's path relative to `out`."""
    found = scene_files(near=out.parent.resolve()).get(scene.name)
    if found is not None and Path(found).resolve() == scene.file.resolve():
        return scene.name
    return Path(os.path.relpath(scene.file.resolve(), out.parent.resolve())).as_posix()


def check_output(out: Path) -> str:
    """The task name `out` gives (its stem); a clear error when it cannot be one, or when another file has it."""
    from robolab_ms.content import content_files

    if out.suffix != ".yaml":
        raise RoboLabError(f"--out {out}: a task file ends in .yaml")
    name = out.stem
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
        raise RoboLabError(
            f"--out {out}: the file name is the task name and must be usable in an environment id "
            f"(RoboLab-{name}-v1): letters, digits and underscores, starting with a letter, e.g. "
            "MugLeftOfBowl.yaml"
        )
    known = content_files("tasks").get(name)
    if known is not None and Path(known).resolve() != out.resolve():
        raise RoboLabError(f"--out {out}: task '{name}' already exists ({known}); choose another file name")
    return name


# ------------------------------------------------------------------------------------------------ prompts
def task_system_prompt(scene: SceneSpec, catalog: Catalog) -> str:
    """The instructions for the model: the answer format, the frame, our predicates, attributes and checks."""
    from robolab_ms.policies.oracle import SOLVABLE_PREDICATES

    lines = [
        "You write tasks for a robot manipulation benchmark: a Franka arm with a two-finger gripper (85 mm open) at "
        "a table. Given an instruction and a scene, answer with ONE JSON object and nothing else:",
        '{"episode_seconds": S, "attributes": [...], "instructions": {"default": ..., "vague": ..., "specific": ...}, '
        '"success": [CONDITION, ...], "subtasks": [STAGE, ...] (optional)}',
        'CONDITION: {"predicate": P, "objects": [scene object names], <reference fields of P>: a scene object name '
        'or "table", "logical": "all" | "any" | "choose" (default all), "k": N (with choose: exactly N objects), '
        "flags, parameters of P}. Any one condition of the list suffices.",
        FRAME,
        "Predicates (name(reference fields; parameters with defaults): meaning):",
    ]
    for name, info in PREDICATES.items():
        references = ", ".join(key + (f"={default}" if default else "") for key, default in info.references.items())
        params = ", ".join(f"{key}={value}" for key, value in info.params.items())
        fields = "; ".join(part for part in (references, params) if part)
        lines.append(f"- {name}({fields}): {' '.join(info.doc.split())}")
    lines += [
        f"The FIRST condition must use one of {', '.join(SOLVABLE_PREDICATES)}: an oracle policy solves the task "
        "from it to prove it solvable (it moves the objects of `any` one at a time, the first of a spatial "
        "condition only, so give a spatial condition one object).",
        "Flags (all predicates): require_contact_with: true (the object touches the first reference: use it for "
        "into / onto a container or object when one object goes there); require_gripper_detached: true (let go of "
        "it: use it wherever the object is left somewhere, never with picked_up or grasped); require_picked_up: "
        "true (it must have been picked up at some step: use it when an object could be knocked into place).",
        "Attributes (RoboLab's vocabulary; list those that apply): "
        + "; ".join(f"{key}: {value}" for key, value in ATTRIBUTE_MEANINGS.items() if key in AXIS_OF_ATTRIBUTE)
        + ".",
        "Instructions: default is the user's instruction as given; vague states the goal without naming the "
        "objects or the place directly, with one sensible reading in this scene; specific names every object by "
        "its colour or look and every step in order, letting go included when the condition needs it. Name only "
        "objects of the scene and colours they have.",
        'STAGE (subtasks, optional; default per object: grasped, then the first condition): {"objects": [...], '
        '"logical": ..., "steps": [{"predicate": P, <its fields without objects>, "weight": W}, ...]}.',
        "episode_seconds: about 30 to lift, turn or place one object beside another, 50 to put one into or onto "
        "another, 60 for two or three, 20 more for each further object.",
        "Checks: the task loader reads your answer (its errors come back to you), a judge checks that the "
        "condition matches the instruction, and validation runs the scene at rest, a random policy (must fail), "
        "and the oracle (must succeed). What fails comes back as feedback; then answer again with the whole "
        "corrected JSON object. Do not give name or scene: they are set for you.",
    ]
    return "\n".join(lines)


def task_user_prompt(instruction: str, scene: SceneSpec, catalog: Catalog) -> str:
    return (
        f"{INSTRUCTION_PREFIX}{instruction}\n\nScene '{scene.name}': {scene.description}\nObjects (name: "
        f"catalog object, class, colours, place):\n{scene_listing(scene, catalog)}"
    )


# ------------------------------------------------------------------------------------------------ task files
def _inline(value: Any) -> str:
    """A value in YAML flow style on one line."""
    text = yaml.safe_dump(value, default_flow_style=True, width=100000, allow_unicode=True, sort_keys=False).strip()
    return text[: -len("\n...")].strip() if text.endswith("\n...") else text


def task_text(data: dict[str, Any], header: str = "") -> str:
    """A task spec's data as a task file, laid out as the shipped ones: short lists and steps on one line."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    keys = [key for key in TASK_KEYS if key in data] + [key for key in data if key not in TASK_KEYS]
    for key in keys:
        value = data[key]
        if key == "instructions" and isinstance(value, dict):
            lines.append("instructions:")
            lines += [f"  {_inline(variant)}: {_inline(text)}" for variant, text in value.items()]
        elif key in ("success", "subtasks") and isinstance(value, list):
            lines.append(f"{key}:")
            for item in value:
                if not isinstance(item, dict) or not item:
                    lines.append(f"  - {_inline(item)}")
                    continue
                for number, (field_name, field_value) in enumerate(item.items()):
                    lead = "  - " if number == 0 else "    "
                    if field_name == "steps" and isinstance(field_value, list):
                        lines.append(f"{lead}steps:")
                        lines += [f"      - {_inline(step)}" for step in field_value]
                    else:
                        lines.append(f"{lead}{_inline(field_name)}: {_inline(field_value)}")
        else:
            lines.append(f"{_inline(key)}: {_inline(value)}")
    return "\n".join(lines) + "\n"


def task_data(answer: dict[str, Any], name: str, scene: str, instruction: str) -> dict[str, Any]:
    """The task file's content from an answer: name and scene set, the default instruction the user's."""
    data: dict[str, Any] = {"name": name, "scene": scene}
    data.update({key: value for key, value in answer.items() if key not in ("name", "scene")})
    instructions = data.get("instructions")
    if isinstance(instructions, dict):
        given = {**instructions, "default": tidy(instruction)}
        data["instructions"] = {key: given[key] for key in (*INSTRUCTION_VARIANTS, *given) if key in given}
    return data


def _spec_feedback(error: RoboLabError, file: Path) -> str:
    """The loader's error for the model: the field and the fix, without our temporary path."""
    return str(error).replace(f"{file}: ", "the task: ").replace(str(file), "the task")


# ------------------------------------------------------------------------------------------------ generation
def generate_task(
    scene: str | Path | SceneSpec,
    instruction: str,
    out: str | Path,
    model: JsonModel,
    judge: Judge,
    rounds: int = DEFAULT_ROUNDS,
    seeds: int = DEFAULT_SEEDS,
    first_seed: int = 0,
    catalog: Catalog | None = None,
    show_progress: bool = False,
) -> TaskGeneration:
    """Generate a task for `instruction` on `scene` (a name, a scene file or a SceneSpec) into `out` (its stem is
    the task's name). `seeds`: validation seeds per round (0 skips validation). The transcript is saved whatever
    happens."""
    from robolab_ms.policies.oracle import SOLVABLE_PREDICATES

    if rounds < 1:
        raise RoboLabError(f"--rounds {rounds}: give at least 1")
    if seeds < 0:
        raise RoboLabError(f"--seeds {seeds}: give 0 (no validation) or more")
    if first_seed < 0:
        raise RoboLabError(f"--seed {first_seed}: give 0 or more (the validation seeds are --seed, --seed+1, ...)")
    if not instruction.strip():
        raise RoboLabError("the instruction is empty: say what the robot should do, e.g. 'Put the banana in the bowl'")
    out = Path(out)
    name = check_output(out)
    catalog = catalog or load_catalog()
    scene_spec = scene if isinstance(scene, SceneSpec) else resolve_scene(scene)
    final_scene = scene_field(scene_spec, out)
    started = time.perf_counter()
    result = TaskGeneration(instruction=instruction, scene=scene_spec.name)
    transcript = Transcript(kind="task", prompt=instruction, backend=model.name)
    transcript.system = task_system_prompt(scene_spec, catalog)
    messages = [{"role": "user", "content": task_user_prompt(instruction, scene_spec, catalog)}]
    try:
        with tempfile.TemporaryDirectory(prefix="robolab_task_") as folder:
            candidate = Path(folder) / f"{name}.yaml"
            for round_number in range(1, rounds + 1):
                result.rounds = round_number
                checks: dict[str, Any] = {}
                feedback: list[str] = []
                answer, raw = None, ""
                try:
                    answer, raw = model.ask_json(transcript.system, messages)
                except GenerationError as exc:
                    raw, feedback, result.stopped_at = exc.raw, [str(exc)], "answer"
                spec = None
                if answer is not None:
                    data = task_data(answer, name, str(scene_spec.file.resolve()), instruction)
                    candidate.write_text(task_text(data), encoding="utf-8")
                    try:
                        spec = read_task(candidate)
                        result.condition = data["success"][0] if isinstance(data.get("success"), list) else None
                        checks["schema"] = "ok"
                    except RoboLabError as exc:  # SpecError mostly; any refusal of the loader is feedback
                        feedback, result.stopped_at = [_spec_feedback(exc, candidate)], "schema"
                        checks["schema"] = feedback[0]
                if spec is not None:
                    feedback = _check_task(
                        spec,
                        instruction,
                        judge,
                        seeds,
                        first_seed,
                        Path(folder),
                        round_number,
                        result,
                        checks,
                        show_progress,
                        SOLVABLE_PREDICATES,
                    )
                transcript.record(messages, raw, feedback, checks=checks)
                if spec is not None and not feedback:
                    result.accepted, result.problems, result.stopped_at = True, [], "accepted"
                    result.task_file = _write_final(data, final_scene, out, model, judge, result, seeds)
                    break
                result.problems = feedback
                messages = [
                    *messages,
                    {"role": "assistant", "content": raw},
                    {"role": "user", "content": feedback_message(feedback)},
                ]
        result.seconds = time.perf_counter() - started
        transcript.outcome = "accepted" if result.accepted else "failed: " + "; ".join(result.problems)
    finally:
        result.transcript = transcript.save(out)
    return result


def _check_task(
    spec: TaskSpec,
    instruction: str,
    judge: Judge,
    seeds: int,
    first_seed: int,
    folder: Path,
    round_number: int,
    result: TaskGeneration,
    checks: dict[str, Any],
    show_progress: bool,
    solvable: tuple[str, ...],
) -> list[str]:
    """Checks 2 to 4 of one answer that the loader read; the feedback (empty when the task is accepted)."""
    predicate = spec.success[0].predicate
    if predicate not in solvable:
        result.stopped_at = "solvable"
        checks["solvable"] = f"no: {predicate}"
        return [
            f"success[0] uses '{predicate}', which the oracle cannot solve, so validation cannot prove the task "
            f"solvable; put a condition with one of {', '.join(solvable)} first"
        ]
    judgement = judge.judge(tidy(instruction), spec)
    if isinstance(judge, ModelJudge) and judge.transcript:
        checks["judge_conversation"] = judge.transcript[-1]
    checks["judge"] = judgement.to_dict()
    result.judgement = judgement
    if result.first_judgement is None:
        result.first_judgement = judgement
    if judgement.verdict not in (ALIGNED, UNSURE):
        result.stopped_at = "judge"
        return [
            f"the judge ({judgement.judge}) finds the condition does not match the instruction: {problem}"
            for problem in judgement.problems
        ]
    if seeds == 0:
        checks["validate"] = "skipped (--seeds 0)"
        return []
    from robolab_ms.eval.validate import validate_task

    began = time.perf_counter()
    row = validate_task(
        str(spec.file), seeds, folder / f"validate_{round_number}", first_seed, show_progress=show_progress
    )
    result.validate_seconds += time.perf_counter() - began
    result.validation = row
    checks["validate"] = asdict(row)
    if row.passed:
        return []
    result.stopped_at = "validate"
    feedback = [f"robolab validate ({seeds} seed(s)): {problem}" for problem in row.problems.split("; ") if problem]
    if row.oracle_failures:
        feedback.append(f"why the oracle failed: {row.oracle_failures}")
    if row.oracle_errors:
        feedback.append(f"the oracle gave up: {row.oracle_errors}")
    return feedback


def _write_final(
    data: dict[str, Any], scene: str, out: Path, model: JsonModel, judge: Judge, result: TaskGeneration, seeds: int
) -> Path:
    """Write the accepted task to `out` (its scene as the loader finds it from there) and read it back."""
    data = {**data, "scene": scene}
    row = result.validation
    proof = (
        f"robolab validate with {seeds} seed(s) passed: oracle {row.oracle_success:.0%}, random policy "
        f"{row.random_success:.0%}, largest drift at rest {row.max_drift_cm:g} cm"
        if row is not None
        else "not validated (--seeds 0)"
    )
    verdict = result.judgement.verdict if result.judgement else "-"
    header = (
        f"Generated by `robolab generate task` (backend {model.name}, judge {judge.name}: {verdict}) from the "
        f"instruction in `default`.\n{proof}."
    )
    make_folder(out.parent, "--out")
    out.write_text(task_text(data, header), encoding="utf-8")
    read_task(out.resolve())
    return out
