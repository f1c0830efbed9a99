"""The judge of generated tasks: does the success condition match the instruction?

RoboLab asks an LLM whether each generated task's condition matches its instruction (76 % of its 812 generated
tasks were judged aligned). `ModelJudge` does the same through an OpenAI-compatible endpoint. `RulesJudge` needs
no network: it reads the instruction against the scene (robolab_ms.generation.instruction) and checks each success
condition against that reading:

- the relation word maps to the predicate ("in" -> in_container, enclosed, placed_in_container_in_order,
  groups_in_containers or on_top; "left of" -> left_of; "pick up" -> picked_up; ...);
- the object the instruction refers to ("in the grey bin") is the condition's container or reference;
- every object the instruction names is in the condition, and the condition moves no object it does not name
  (colour, size and position words narrow what a noun names: "the red mug" is not the white one);
- the counts agree: "all", plurals and "both" need every matching object, a number N needs N, "a" and "or" one.

It says `unsure` when it cannot read the instruction (no relation word or no object it knows), rather than
guessing. The offline task backend builds its conditions from the same reading, so on its own answers the rules
judge mostly checks the backend's bookkeeping; on conditions written by others (the shipped tasks, an LLM's) it
is an independent check (docs/generation.md measures it on the 120 hand-written tasks).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, Protocol

from robolab_ms.catalog import Catalog
from robolab_ms.generation.instruction import Mention, Reading, SceneVocabulary, read_instruction, rests_in
from robolab_ms.generation.llm import GenerationError, JsonModel
from robolab_ms.generation.proposal import FRAME
from robolab_ms.scene import SceneSpec
from robolab_ms.tasks.condition import Condition
from robolab_ms.tasks.predicates import PREDICATES
from robolab_ms.tasks.spec import TaskSpec

ALIGNED, MISALIGNED, UNSURE = "aligned", "misaligned", "unsure"
ALLOWED = {  # the reading's relation -> predicates that express it
    "in": {"in_container", "enclosed", "placed_in_container_in_order", "groups_in_containers", "on_top"},
    "to": {"in_container", "enclosed", "on_top", "groups_in_containers", "placed_in_container_in_order"},
    "away": {"in_container", "enclosed", "groups_in_containers", "placed_in_container_in_order"},
    "on": {"on_top", "in_container", "enclosed", "stacked", "placed_in_container_in_order"},
    "stack": {"stacked", "on_top", "in_container"},
    "left_of": {"left_of"}, "right_of": {"right_of"}, "in_front_of": {"in_front_of"}, "behind": {"behind"},
    "next_to": {"next_to"}, "center": {"on_center"}, "pick": {"picked_up", "grasped"}, "upright": {"upright"},
    "out": {"outside_of", "outside_of_and_on_surface"}, "clear": {"outside_of", "outside_of_and_on_surface"},
}  # fmt: skip


@dataclass
class Judgement:
    """A judge's verdict on one task: aligned, misaligned (with the problems, as feedback for the model) or unsure."""

    verdict: str
    problems: list[str] = field(default_factory=list)
    judge: str = "rules"

    @property
    def aligned(self) -> bool:
        return self.verdict == ALIGNED

    def to_dict(self) -> dict[str, Any]:
        return {"verdict": self.verdict, "problems": list(self.problems), "judge": self.judge}


class Judge(Protocol):
    name: str

    def judge(self, instruction: str, spec: TaskSpec) -> Judgement: ...


def condition_place(condition: Condition) -> list[str]:
    """The objects a condition puts things into, onto or beside: its reference values, or its groups' containers."""
    if "groups" in condition.params:
        return list(condition.params["groups"])
    return [value for key, value in condition.references.items() if key != "surface"]


class RulesJudge:
    """The rules judge (see the module's docstring)."""

    name = "rules"

    def __init__(self, catalog: Catalog) -> None:
        self.catalog = catalog

    def judge(self, instruction: str, spec: TaskSpec) -> Judgement:
        vocabulary = SceneVocabulary(spec.scene, self.catalog)
        reading = read_instruction(instruction, spec.scene, self.catalog, vocabulary)
        main = reading.main()
        if main is None:
            return Judgement(
                UNSURE,
                [
                    "no relation word the rules know (in, on, left of, pick up, upright, out of, "
                    "stack ...) with an object of the scene"
                ],
            )
        problems = [
            f"the instruction names '{word}', which is not in the scene"
            for word in dict.fromkeys(reading.missing)
            if not any(word in m.text for m in reading.mentions)
        ]
        for index, condition in enumerate(spec.success):
            where = f"success[{index}] ({condition.predicate})" if len(spec.success) > 1 else "the condition"
            found = self._check(reading, condition, vocabulary, len(spec.subtasks))
            problems += [f"{where}: {problem}" for problem in found]
        return Judgement(MISALIGNED if problems else ALIGNED, problems)

    def _check(self, reading: Reading, condition: Condition, vocabulary: SceneVocabulary, stages: int) -> list[str]:
        main = reading.main()
        assert main is not None
        kinds = {a.kind for a in reading.actions if a.targets or a.kind == "clear"} or {main.kind}
        allowed = set().union(*(ALLOWED[kind] for kind in kinds))
        problems = []
        words = " / ".join(sorted({a.word for a in reading.actions if a.kind in kinds}))
        if condition.predicate not in allowed:
            problems.append(
                f"the instruction says '{words}', which '{condition.predicate}' does not express; use "
                + " or ".join(sorted(allowed))
            )
        # the place: the container or reference the instruction names
        places = condition_place(condition)
        actions = [a for a in reading.actions if a.kind in kinds]
        named_places = [a.reference for a in actions if a.reference is not None]
        if any(a.table_reference for a in actions) and not named_places:
            if condition.predicate in ("on_center", "left_of", "right_of", "in_front_of", "behind", "next_to") and (
                places and places[0] != "table"
            ):
                problems.append(f"the instruction refers to the table, the condition to '{places[0]}'")
        for mention in named_places:
            if condition.predicate == "stacked":
                if not set(mention.candidates) & set(condition.objects):
                    problems.append(f"the instruction stacks onto {_what(mention)}, which is not in the stack")
            elif places and not set(mention.candidates) & set(places):
                problems.append(
                    f"the instruction refers to {_what(mention)}, the condition to "
                    + ", ".join(f"'{p}'" for p in places)
                )
        if main.kind == "away" and places:
            if not all(
                vocabulary.objects[p].entry.is_container or vocabulary.objects[p].entry.is_fixture
                for p in places
                if p in vocabulary.objects
            ):
                problems.append("the instruction puts things away, but the condition's place is not a container")
        # the order: "A in the bowl, then B" needs the placements in that order, and nothing else does
        in_actions = [a for a in actions if a.kind in ("in", "to", "on", "away") and a.targets]
        ordered = reading.ordered and len(in_actions) > 1 and any(a.after_then for a in in_actions[1:])
        if condition.predicate == "placed_in_container_in_order":
            sequence = [c for a in in_actions for m in a.targets for c in m.candidates]
            positions = [sequence.index(o) for o in condition.objects if o in sequence]
            if not ordered:
                problems.append(
                    "the condition asks for the objects in a fixed order (placed_in_container_in_order), "
                    "the instruction names no order; use in_container"
                )
            elif positions != sorted(positions):
                problems.append(
                    "the condition's order of objects is not the instruction's: list them as the instruction names them"
                )
        elif ordered and condition.predicate == "in_container" and stages < 2:
            problems.append(
                "the instruction says which goes first ('then'); use placed_in_container_in_order, or "
                "subtasks with one stage per step"
            )
        # the objects: each one named is in the condition, and nothing else is moved
        mentions = list({id(m): m for a in actions for m in a.targets}.values())
        reference_names = {c for m in named_places for c in m.candidates[:1]}
        moved = [o for o in condition.objects if not (condition.predicate == "stacked" and o in reference_names)]
        if main.kind == "clear":  # "clear the plate": the place checked above; what rests on it is the scene's
            return problems
        named = {c for m in mentions for c in m.candidates}
        for mention in mentions:
            if not set(mention.candidates) & set(moved):
                problems.append(
                    f"the instruction names {_what(mention)}, but the condition moves none of "
                    f"{_names(mention.candidates) or 'them'}"
                )
        for name in moved:
            if name not in named:
                problems.append(self._stray(name, mentions, vocabulary))
        # the count: how many the instruction asks for against how many the condition needs
        out_of = [vocabulary.objects[p] for p in places if p in vocabulary.objects] if main.kind == "out" else []
        if mentions and not problems:
            wanted = self._wanted(mentions, actions, vocabulary, out_of)
            needed = condition.required_count - (1 if condition.predicate == "stacked" and reference_names else 0)
            if wanted != needed:
                problems.append(
                    f"the instruction asks for {wanted} object(s), the condition needs {needed} "
                    f"({condition.logical}{f' {condition.k}' if condition.logical == 'choose' else ''} "
                    f"of {len(condition.objects)})"
                )
            for mention in mentions:
                expected = [c for c in mention.candidates if not out_of or rests_in(vocabulary.objects[c], out_of[0])]
                if mention.wanted() is None and not set(expected) <= set(moved):
                    left = [c for c in expected if c not in moved]
                    problems.append(
                        f"the instruction asks for all of {_what(mention)}, the condition leaves out {_names(left)}"
                    )
        return problems

    @staticmethod
    def _wanted(mentions: list[Mention], actions: list, vocabulary: SceneVocabulary, out_of: list) -> int:
        """How many objects the instruction asks for ("take the bananas out of the bin": those in the bin)."""
        if any(a.alternatives for a in actions):
            return 1
        every: set[str] = set()  # "the plastic bottles and jugs": objects both words name count once
        total = 0
        for mention in mentions:
            wanted = mention.wanted()
            pool = [c for c in mention.candidates if not out_of or rests_in(vocabulary.objects[c], out_of[0])]
            if wanted is None:
                every.update(pool or mention.candidates)
            else:
                total += wanted
        return total + len(every)

    @staticmethod
    def _stray(name: str, mentions: list[Mention], vocabulary: SceneVocabulary) -> str:
        """Why an object of the condition is not what the instruction names ("'mug_white' is not red")."""
        obj = vocabulary.objects.get(name)
        for mention in mentions:
            if name in mention.noun_candidates and obj is not None:
                if mention.colours and not set(mention.colours) & set(obj.colours):
                    return (
                        f"the condition moves '{name}', which is not {' '.join(mention.colours)} (its colours: "
                        f"{', '.join(obj.colours) or 'none'})"
                    )
                return f"the condition moves '{name}', which {_what(mention)} does not mean here"
        return f"the condition moves '{name}', which the instruction does not name"


def _what(mention: Mention) -> str:
    return f"'{mention.text}'"


def _names(names: list[str]) -> str:
    return ", ".join(f"'{n}'" for n in names)


# ------------------------------------------------------------------------------------------------ the LLM judge
def judge_system_prompt() -> str:
    """The instructions for an LLM judge."""
    lines = [
        "You check tasks of a robot manipulation benchmark. A task has an instruction in plain words and a success "
        "condition written with predicates over the scene's objects. Decide whether the condition matches the "
        "instruction: a robot that makes the condition true has done what the instruction asks, and a person who "
        "does what the instruction asks makes the condition true.",
        "Check: every object the instruction names is in the condition, and the condition moves no other object; "
        "the relation words match the predicate; the container or reference is the one the instruction names; "
        "colours, sizes, positions and counts agree ('all', 'both', numbers, 'a', 'or'). Logical 'all' needs every "
        "object, 'any' one of them, 'choose' with k exactly k.",
        FRAME,
        "Predicates:",
    ]
    for name, info in PREDICATES.items():
        doc = " ".join(info.doc.split())
        lines.append(f"- {name}: {doc}")
    lines.append(
        'Answer with ONE JSON object and nothing else: {"aligned": true or false, "problems": ["what does '
        'not match, one sentence each; empty when aligned"]}'
    )
    return "\n".join(lines)


def scene_listing(scene: SceneSpec, catalog: Catalog) -> str:
    """The scene's objects, one a line: name, catalog object, class, colours, place, support, container mark."""
    lines = []
    for placement in scene.objects:
        entry = catalog[placement.asset]
        marks = " (container)" if entry.is_container else " (shelf, fixed)" if entry.is_fixture else ""
        on = f", on {placement.on}" if placement.on else ""
        colours = "/".join(entry.colors) or "-"
        lines.append(
            f"- {placement.name}: {placement.asset}, {entry.object_class}, colours {colours}, "
            f"at x={placement.xy[0]:.2f} y={placement.xy[1]:.2f}{on}{marks}"
        )
    return "\n".join(lines)


def condition_data(condition: Condition) -> dict[str, Any]:
    """A condition as the task file writes it."""
    data: dict[str, Any] = {"predicate": condition.predicate, "objects": list(condition.objects)}
    data.update({key: value for key, value in condition.references.items()})
    if condition.logical != "all":
        data["logical"] = condition.logical
    if condition.logical == "choose":
        data["k"] = condition.k
    for flag in ("require_contact_with", "require_gripper_detached", "require_picked_up"):
        if getattr(condition, flag):
            data[flag] = True
    data.update(
        {
            key: value
            for key, value in condition.params.items()
            if value != PREDICATES[condition.predicate].params.get(key)
        }
    )
    return data


class ModelJudge:
    """An LLM as the judge, through the same client as generation (`ask_json`)."""

    def __init__(self, model: JsonModel, catalog: Catalog) -> None:
        self.model = model
        self.catalog = catalog
        self.name = f"model:{model.name}"
        self.transcript: list[dict[str, Any]] = []  # every question asked and answer got

    def judge(self, instruction: str, spec: TaskSpec) -> Judgement:
        question = (
            f"Scene objects:\n{scene_listing(spec.scene, self.catalog)}\n\nInstruction: {instruction}\n\n"
            "Success condition (any one of these suffices):\n"
            + json.dumps([condition_data(c) for c in spec.success], indent=1)
        )
        messages = [{"role": "user", "content": question}]
        try:
            answer, raw = self.model.ask_json(judge_system_prompt(), messages)
        except GenerationError as exc:
            self.transcript.append({"messages": messages, "answer": exc.raw, "error": str(exc)})
            return Judgement(UNSURE, [f"the judge's answer could not be read: {exc}"], self.name)
        self.transcript.append({"messages": messages, "answer": raw})
        aligned = answer.get("aligned")
        problems = answer.get("problems") or []
        if isinstance(problems, str):
            problems = [problems]
        problems = [str(p) for p in problems if str(p).strip()]
        if not isinstance(aligned, bool):
            return Judgement(UNSURE, [f"the judge answered without a true/false 'aligned': {raw[:200]}"], self.name)
        if aligned:
            return Judgement(ALIGNED, [], self.name)
        return Judgement(
            MISALIGNED, problems or ["the judge found the condition does not match the instruction"], self.name
        )
