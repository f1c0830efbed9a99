"""The offline scene backend: a deterministic stand-in for the LLM that needs no network.

From the prompt's nouns it picks catalog objects (by name, class and colour: "two red blocks", "the white bowl",
"a soup can"), and from the relation words between them it builds the relations of the answer format ("A left of
B", "A in B", "A on B", "a stack of A, B and C", "in a row", "facing the robot", "scattered"). Objects joined by
"and" share the relation that follows them ("a banana and an apple in the bowl"). It answers the feedback of later
rounds the simple way: it drops the objects and relations the feedback names (an unstable object loses its
support and stands on the table). The same prompt always gives the same answer.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field

from robolab_ms.catalog import Catalog
from robolab_ms.generation.proposal import MAX_OBJECTS

NUMBERS = {"a": 1, "an": 1, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "pair": 2}
SYNONYMS = {  # a prompt's word -> a word of catalog names or classes
    "cup": "mug",
    "mugs": "mug",
    "teacup": "cup",
    "jar": "can",
    "tin": "can",
    "box": "box",
    "carton": "carton",
    "cube": "block",
    "brick": "brick",
    "toy": "toy",
    "tray": "tray",
    "pot": "pot",
    "kettle": "teapot",
    "pan": "pan",
    "phone": "smartphone",
    "mobile": "smartphone",
    "glasses": "eyeglasses",
    "drill": "drill",
    "clamp": "clamp",
    "pen": "marker",
    "pens": "marker",
    "bucket": "pail",
    "basket": "basket",
    "crate": "crate",
    "bin": "bin",
    "bowl": "bowl",
    "plate": "plate",
    "dish": "plate",
    "ball": "sphere",
    "tomato": "tomato",
    "bread": "bread",
    "soap": "sponge",
    "bottle": "bottle",
    "jug": "jug",
    "book": "book",
    "ruler": "marker",
}
CONNECTORS = {"and", ",", "plus"}
MODIFIERS = {
    "large",
    "small",
    "big",
    "tall",
    "short",
    "wide",
    "slim",
    "medium",
    "mini",
    "plain",
    "curved",
    "ceramic",
    "scan",
    "akita",
    "libero",
    "wooden",
    "square",
    "new",
    "deep",
    "long",
    "round",
    "flat",
    "left",
    "right",
    "low",
    "brass",
    "clear",
    "screwtop",
    "gable",
    "wicker",
    "little",
    "tiny",
    "huge",
}
STOP = {
    "the",
    "a",
    "an",
    "some",
    "of",
    "to",
    "its",
    "their",
    "it",
    "them",
    "is",
    "are",
    "put",
    "place",
    "set",
    "lay",
    "stand",
    "standing",
    "sits",
    "sitting",
    "there",
    "scene",
    "table",
    "desk",
    "counter",
    "on",
    "in",
    "at",
    "by",
    "from",
    "cm",
    "m",
}


@dataclass
class Mention:
    """A noun phrase of the prompt that names a catalog object."""

    start: int  # token span
    end: int
    asset: str
    name: str = ""
    refers_to: Mention | None = None  # "the bowl" after "a white bowl": the same object


@dataclass
class OfflinePlan:
    """The answer the offline backend builds from a prompt: objects and relations as the JSON format has them."""

    objects: list[dict[str, str]] = field(default_factory=list)
    relations: list[dict] = field(default_factory=list)


def tokens_of(text: str) -> list[str]:
    return re.findall(r"\d+(?:\.\d+)?|[a-z]+|[,.;]", text.lower())


def singular(word: str) -> str:
    for ending, replacement in (("ies", "y"), ("ches", "ch"), ("shes", "sh"), ("xes", "x"), ("oes", "o"), ("s", "")):
        if word.endswith(ending) and len(word) > len(ending) + 2 and not word.endswith("ss"):
            return word[: -len(ending)] + replacement
    return word


class OfflineSceneModel:
    """Answers scene prompts (and the grid baseline's prompts) without a network; see the module's docstring."""

    name = "offline"

    def __init__(self, catalog: Catalog) -> None:
        self.catalog = catalog
        self.colours = sorted({colour for name in catalog.names() for colour in catalog[name].colors})
        self.words: dict[str, list[str]] = {}  # a word or two-word phrase -> catalog names it can mean
        for name in catalog.names():
            entry = catalog[name]
            if entry.is_fixture:
                continue
            parts = name.split("_")
            nouns = {
                part
                for part in parts
                if part.isalpha()
                and len(part) > 2
                and part not in MODIFIERS
                and part not in self.colours
                and part not in STOP
                and part != "and"
            }
            phrases = {*nouns, " ".join(parts), entry.object_class}
            phrases |= {
                " ".join(parts[i : i + 2]) for i in range(len(parts) - 1) if parts[i] in nouns and parts[i + 1] in nouns
            }
            for phrase in phrases:
                self.words.setdefault(phrase, []).append(name)

    # ------------------------------------------------------------------------------------------------ the protocol
    def ask_json(self, system: str, messages: list[dict[str, str]]) -> tuple[dict, str]:
        """The answer to the conversation: the plan of its first user message, less what later feedback named."""
        from robolab_ms.generation.grid import GRID_MARKER

        prompt = messages[0]["content"]
        plan = self.plan(prompt)
        if GRID_MARKER in system:
            answer = grid_answer(plan)
        else:
            for message in messages[1:]:
                if message["role"] == "user":
                    plan = apply_feedback(plan, message["content"])
            answer = {"objects": plan.objects, "relations": plan.relations}
        return answer, json.dumps(answer)

    # ------------------------------------------------------------------------------------------------ prompt -> plan
    def plan(self, prompt: str) -> OfflinePlan:
        """Objects and relations from the prompt's words (deterministic)."""
        text = prompt.split("\n\nThe scene must contain:")[0]
        required = re.findall(r"The scene must contain: ([a-z0-9_, ]+)", prompt)
        tokens = tokens_of(text)
        mentions = self._mentions(tokens)
        for asset in required[0].split(", ") if required else []:
            if asset in self.catalog.names() and asset not in [m.asset for m in mentions]:
                mentions.append(Mention(len(tokens), len(tokens), asset))
        new = [m for m in mentions if m.refers_to is None][:MAX_OBJECTS]
        mentions = [m for m in mentions if m.refers_to in new or m in new]
        counts: dict[str, int] = {}
        for mention in new:
            counts[mention.asset] = counts.get(mention.asset, 0) + 1
        seen: dict[str, int] = {}
        for mention in new:
            seen[mention.asset] = seen.get(mention.asset, 0) + 1
            mention.name = mention.asset if counts[mention.asset] == 1 else f"{mention.asset}_{seen[mention.asset]}"
            for later in mentions:  # references back to it ("the bowl") share its name
                if later.refers_to is mention:
                    later.name = mention.name
        plan = OfflinePlan(objects=[{"name": m.name, "asset": m.asset} for m in new])
        plan.relations = self._relations(tokens, mentions)
        return plan

    def _mentions(self, tokens: list[str]) -> list[Mention]:
        mentions: list[Mention] = []
        index = 0
        while index < len(tokens):
            count, start = 1, index
            counted = tokens[index] in NUMBERS and tokens[index] not in ("a", "an") or tokens[index].isdigit()
            if tokens[index] in NUMBERS or tokens[index].isdigit():
                count = NUMBERS.get(tokens[index]) or min(int(tokens[index]), 6)
                index += 1
            colours, modifiers = [], []
            while index < len(tokens) and (tokens[index] in self.colours or tokens[index] in MODIFIERS):
                (colours if tokens[index] in self.colours else modifiers).append(tokens[index])
                index += 1
            found = self._noun(tokens, index)
            if found is None and colours and colours[-1] in self.words:  # "an orange": the colour is the noun
                index -= 1
                colours.pop()
                found = self._noun(tokens, index)
            if found is None:
                index = start + 1
                continue
            length, candidates = found
            if index + length < len(tokens) and tokens[index + length] in ("cm", "m"):
                index = start + 1
                continue
            definite = start > 0 and tokens[start - 1] in ("the", "that", "this", "same")
            earlier = [m for m in mentions if m.refers_to is None and m.asset in candidates]
            earlier = [m for m in earlier if all(c in self.catalog[m.asset].colors for c in colours)] or earlier
            if definite and not counted and earlier:
                mentions.append(Mention(start, index + length, earlier[-1].asset, refers_to=earlier[-1]))
            else:
                for asset in self._choose(candidates, colours, modifiers, tokens[index : index + length], count):
                    mentions.append(Mention(start, index + length, asset))
            index += length
        return mentions

    def _noun(self, tokens: list[str], index: int) -> tuple[int, list[str]] | None:
        """The longest phrase at `index` (up to three words) that names catalog objects: (its length, names)."""
        for length in (3, 2, 1):
            words = tokens[index : index + length]
            if len(words) < length or any(word in STOP or not word.isalpha() for word in words):
                continue
            phrase = " ".join(words[:-1] + [singular(words[-1])])
            for candidate in (
                phrase,
                " ".join(words),
                SYNONYMS.get(phrase, ""),
                SYNONYMS.get(singular(words[-1]), "") if length == 1 else "",
            ):
                if candidate and candidate in self.words:
                    return length, self.words[candidate]
        return None

    def _choose(
        self, candidates: list[str], colours: list[str], modifiers: list[str], words: list[str], count: int
    ) -> list[str]:
        """`count` catalog names for a phrase: matching colours and modifiers first, then the plainest name."""
        phrase = "_".join(words[:-1] + [singular(words[-1])])

        def rank(name: str) -> tuple:
            entry = self.catalog[name]
            parts = name.split("_")
            colour_hits = sum(colour in entry.colors for colour in colours)
            colour_first = not colours or (bool(entry.colors) and entry.colors[0] == colours[0])
            modifier_hits = sum(modifier in parts for modifier in modifiers)
            extra = len([part for part in parts if part in MODIFIERS]) - modifier_hits
            return (-colour_hits, not colour_first, -modifier_hits, phrase not in name, extra, len(name), name)

        ordered = sorted(candidates, key=rank)
        best = [name for name in ordered if rank(name)[:3] == rank(ordered[0])[:3]]
        if count > 1 and not colours and len(best) >= count:  # "three blocks": three different ones
            return best[:count]
        return [best[0]] * count

    def _relations(self, tokens: list[str], mentions: list[Mention]) -> list[dict]:
        """Relations between the prompt's clauses: "A <relation words> B" with nothing but words between them, "A
        with B inside", lists joined by "and" ("A and B in C"), stacks, rows, facing, scattered."""
        containers = {m.name for m in mentions if self.catalog[m.asset].is_container}
        units: list[list[Mention]] = []  # mentions of one phrase ("three blocks") form one unit
        for mention in mentions:
            if units and units[-1][0].start == mention.start:
                units[-1].append(mention)
            else:
                units.append([mention])
        relations: list[dict] = []
        groups: list[list[Mention]] = []
        group: list[Mention] = []
        group_is_reference = False
        for number, unit in enumerate(units):
            if number == 0:
                group = list(unit)
                groups.append(group)
                continue
            gap_tokens = tokens[units[number - 1][-1].end : unit[0].start]
            gap = _without_row_words(" ".join(gap_tokens))
            separated = bool({",", ".", ";", "and"} & set(gap_tokens))
            relation = None if separated else _relation_words(gap, unit[0].name in containers)
            if not separated and "with" in gap_tokens:  # "a tray with a mug (inside)"
                host = units[number - 1][-1]
                after = []
                for token in tokens[unit[-1].end :]:
                    if token in (",", ".", ";", "and"):
                        break
                    after.append(token)
                kind = "on_top_of" if "on" in after or host.name not in containers else "inside"
                relations.extend({"relation": kind, "object": m.name, "reference": host.name} for m in unit)
                group, group_is_reference = list(unit), True
                groups.append(group)
                continue
            if relation is not None:
                kind, distance = relation
                for subject in group:
                    if subject.name == unit[0].name:
                        continue
                    item = {"relation": kind, "object": subject.name, "reference": unit[0].name}
                    if distance is not None and kind in ("left_of", "right_of", "in_front_of", "behind", "next_to"):
                        item["distance"] = distance
                    if kind == "aligned_with":
                        item["axis"] = "row"
                    relations.append(item)
                group, group_is_reference = list(unit), True
                groups.append(group)
                continue
            listing = set(gap_tokens) <= CONNECTORS | {"the", "a", "an"} and not group_is_reference
            if listing and ("and" in gap_tokens or not self._followed_by_relation(tokens, unit, units, number)):
                group.extend(unit)
            else:
                group, group_is_reference = list(unit), False
                groups.append(group)
        stacks: list[list[str]] = []
        for group in groups:
            before = " ".join(tokens[max(0, group[0].start - 4) : group[0].start])
            after = " ".join(tokens[group[-1].end : group[-1].end + 4])
            names = [m.name for m in group]
            if len(group) >= 2 and (
                re.search(r"\b(stack|pile|tower)(ed)? of\b", before)
                or re.search(r"^(stacked|in a stack|piled)\b", after)
            ):
                stacks.append(names)
                relations.append({"relation": "stacked", "objects": names})
            if len(group) >= 2 and re.search(r"^(in a row|in a line|side by side|lined up)\b", after):
                relations.extend(
                    {"relation": "aligned_with", "object": other, "reference": names[0], "axis": "row"}
                    for other in names[1:]
                )
            if re.search(r"^(facing|turned towards|pointing at) (the robot|you)\b", after):
                relations.extend({"relation": "facing", "object": name, "reference": "robot"} for name in names)
            if re.search(r"^(scattered|at random|randomly|messily)\b", after):
                relations.extend({"relation": "random_yaw", "object": name} for name in names)
        bottom = {name: stack[0] for stack in stacks for name in stack[1:]}  # relations of a stack: its bottom's
        for relation in relations:
            if relation["relation"] != "stacked":
                for key in ("object", "reference"):
                    if relation.get(key) in bottom:
                        relation[key] = bottom[relation[key]]
        return [r for r in _without_repeats(relations) if r["relation"] == "stacked" or r["object"] != r["reference"]]

    def _followed_by_relation(
        self, tokens: list[str], unit: list[Mention], units: list[list[Mention]], number: int
    ) -> bool:
        """Whether relation words (and no comma) lead from this unit to the next one."""
        if number + 1 >= len(units):
            return False
        gap_tokens = tokens[unit[-1].end : units[number + 1][0].start]
        if {",", ".", ";", "and"} & set(gap_tokens):
            return False
        return _relation_words(_without_row_words(" ".join(gap_tokens)), False) is not None or "with" in gap_tokens


def _without_row_words(gap: str) -> str:
    return re.sub(r"\b(in a row|in a line|side by side|lined up|in a stack)\b", " ", gap)


def _without_repeats(relations: list[dict]) -> list[dict]:
    seen, kept = set(), []
    for relation in relations:
        key = json.dumps(relation, sort_keys=True)
        if key not in seen:
            seen.add(key)
            kept.append(relation)
    return kept


def _sentence_spans(tokens: list[str]) -> list[tuple[int, int]]:
    spans, start = [], 0
    for index, token in enumerate(tokens):
        if token in (".", ";"):
            spans.append((start, index))
            start = index + 1
    spans.append((start, len(tokens)))
    return [(a, b) for a, b in spans if b > a]


def _relation_words(gap: str, container: bool) -> tuple[str, float | None] | None:
    """The relation kind the words between two objects name (with a distance in metres if one is said)."""
    if re.search(r"[.;]", gap):
        return None
    distance = None
    measure = re.search(r"(\d+(?:\.\d+)?) ?(cm|m)\b", gap)
    if measure:
        distance = float(measure.group(1)) / (100.0 if measure.group(2) == "cm" else 1.0)
    patterns = [
        (r"\bleft of\b|\bto the left\b", "left_of"),
        (r"\bright of\b|\bto the right\b", "right_of"),
        (r"\bin front of\b|\bbefore\b|\bcloser to the robot than\b", "in_front_of"),
        (r"\bbehind\b|\bbehind of\b|\bfarther than\b|\bbeyond\b", "behind"),
        (r"\bnext to\b|\bbeside\b|\bnear\b|\bby\b", "next_to"),
        (r"\baligned with\b|\bin a row with\b|\bin line with\b", "aligned_with"),
        (r"\bfacing\b|\bturned towards\b|\bpointing at\b", "facing"),
        (r"\bstacked on\b|\bon top of\b|\bontop of\b|\bresting on\b|\bon\b|\bonto\b", "on_top_of"),
        (r"\binside\b|\binto\b|\bin\b|\bfilled\b", "inside"),
    ]
    for pattern, kind in patterns:
        if re.search(pattern, gap):
            if kind == "on_top_of" and container and re.search(r"\bin\b|\binside\b", gap):
                return "inside", distance
            if kind == "inside" and not container:
                return "on_top_of", distance
            return kind, distance
    return None


def apply_feedback(plan: OfflinePlan, feedback: str) -> OfflinePlan:
    """The plan less what the feedback names: unknown objects, the relations it lists, the supports of unstable
    or misfitting objects (which then stand on the table)."""
    objects = list(plan.objects)
    relations = list(plan.relations)
    dropped_relations = {int(i) for i in re.findall(r"relations\[(\d+)\]", feedback)}
    dropped_objects = {int(i) for i in re.findall(r"objects\[(\d+)\]: unknown", feedback)}
    loose = set(re.findall(r"'([A-Za-z0-9_]+)' (?:\([^)]*\) )?(?:moved|fell|does not fit)", feedback))
    objects = [item for index, item in enumerate(objects) if index not in dropped_objects]
    names = {item["name"] for item in objects}
    kept = []
    for index, relation in enumerate(relations):
        if index in dropped_relations:
            continue
        mentioned = set(relation.get("objects", [])) | {relation.get("object"), relation.get("reference")}
        if not (mentioned - {None, "robot"}) <= names:
            continue
        if relation["relation"] in ("on_top_of", "inside") and relation["object"] in loose:
            continue
        if relation["relation"] == "stacked":
            stack = relation["objects"]
            cut = next((i for i, name in enumerate(stack) if name in loose and i > 0), len(stack))
            if cut < 2:
                continue
            relation = {**relation, "objects": stack[:cut]}
        kept.append(relation)
    return OfflinePlan(objects=objects, relations=kept)


def grid_answer(plan: OfflinePlan) -> dict:
    """The grid baseline's answer: the same objects and the smallest near-square grid holding them, row by row."""
    count = max(1, len(plan.objects))
    columns = 1
    while columns * columns < count:
        columns += 1
    rows = -(-count // columns)
    cells = {item["name"]: [index // columns, index % columns] for index, item in enumerate(plan.objects)}
    return {"objects": plan.objects, "grid": {"rows": rows, "columns": columns}, "cells": cells}
