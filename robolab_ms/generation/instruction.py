"""Reading a task instruction against a scene: which objects it names, what it asks done with them, and where.

The offline task backend builds a success condition from a reading; the rules judge checks a condition against
one. A reading has mentions (noun phrases resolved to the scene's objects: by the words of their scene and
catalog names, their catalog class or a category word such as "fruit" or "tools", then narrowed by colour, size
and position words: "the red mug", "the bigger pumpkin", "the left bin") and actions (a relation word with the
mentions it moves and the one it refers to: "put A and B in C", "A to the left of B", "pick up A", "stand A
upright", "take A out of B", "stack A on B", "A in the centre of the table"). Quantities come from the words
before a noun ("all", "both", "two", "a", "or"). Words that name catalog objects which are not in the scene are
kept as `missing`, so a condition cannot be built (or judged right) for an object the scene lacks.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from robolab_ms.catalog import Catalog, CatalogObject
from robolab_ms.generation.offline import MODIFIERS, STOP, SYNONYMS, singular
from robolab_ms.scene import SceneSpec

NUMBER_WORDS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "both": 2}
ALL_WORDS = {"all", "every", "each", "both"}
ANY_WORDS = {"a", "an", "any", "either", "some"}
SIZE_WORDS = {"big": 1, "bigger": 1, "biggest": 1, "large": 1, "larger": 1, "largest": 1, "huge": 1, "tall": 1,
              "taller": 1, "small": -1, "smaller": -1, "smallest": -1, "little": -1, "tiny": -1,
              "short": -1}  # fmt: skip
POSITION_WORDS = {
    "left": (1, 1.0),
    "leftmost": (1, 1.0),
    "right": (1, -1.0),
    "rightmost": (1, -1.0),
    "front": (0, -1.0),
    "near": (0, -1.0),
    "nearest": (0, -1.0),
    "back": (0, 1.0),
    "far": (0, 1.0),
    "farthest": (0, 1.0),
    "rear": (0, 1.0),
}  # word -> (axis, sign): the extreme along x or y
DETERMINERS = {"the", "this", "that", "these", "those", "other", "its", "their"}
ADJECTIVES = MODIFIERS | {
    "plastic",
    "metal",
    "glass",
    "paper",
    "ceramic",
    "wooden",
    "wood",
    "serving",
    "measuring",
    "cordless",
    "canned",
    "cardboard",
    "kitchen",
    "coffee",
    "tea",
}
GENERIC = {"item", "object", "thing", "everything", "stuff"}  # any movable object
CATEGORIES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {  # word -> (catalog classes, name words)
    "fruit": (("fruit",), ()), "vegetable": (("vegetable",), ()), "veggie": (("vegetable",), ()),
    "produce": (("fruit", "vegetable"), ()), "food": (("food", "fruit", "vegetable", "can"), ()),
    "snack": (("food",), ("snack", "cracker", "chip", "cookie", "candy", "bar")),
    "grocery": (("food", "can", "box", "bottle"), ()), "dish": (("tableware",), ("bowl", "plate", "mug", "cup")),
    "dishware": (("tableware",), ("bowl", "plate", "mug", "cup")), "tableware": (("tableware",), ()),
    "utensil": (("utensil",), ()), "cutlery": (("utensil",), ("fork", "knife", "spoon")), "tool": (("tool",), ()),
    "toy": (("toy", "block"), ()), "block": (("block",), ()), "electronic": (("electronics",), ()),
    "electronics": (("electronics",), ()), "device": (("electronics",), ()), "gadget": (("electronics",), ()),
    "bottle": (("bottle",), ("bottle",)), "can": (("can",), ("can",)), "box": (("box",), ("box",)),
    "container": (("container",), ()), "condiment": ((), ("sauce", "ketchup", "mustard", "mayo", "mayonnaise",
                                                         "dressing", "condiment")),
    "animal": ((), ("elephant", "lizard", "animal", "dog", "cat", "horse", "duck", "giraffe")),
}  # fmt: skip
MORE_SYNONYMS = {
    "barbecue": "bbq",
    "cellphone": "smartphone",
    "telephone": "smartphone",
    "spectacles": "eyeglasses",
    "trashcan": "bin",
    "bucket": "pail",
    "tin": "can",
    "puzzle": "rubiks",
    "rubik": "rubiks",
}
STATE_WORDS = {
    "upright",
    "sideways",
    "lying",
    "standing",
    "top",
    "middle",
    "bottom",
    "near",
    "far",
    "left",
    "right",
    "front",
    "back",
    "open",
    "closed",
    "empty",
    "full",
    "big",
    "small",
    "new",
    "old",
}  # in scene names
HEAD_NOUNS = {
    "plate",
    "bowl",
    "mug",
    "bin",
    "box",
    "can",
    "bottle",
    "block",
    "hammer",
    "pumpkin",
    "lime",
    "lemon",
    "jug",
    "cup",
    "spoon",
    "pail",
    "crate",
    "tray",
    "basket",
    "pot",
    "pan",
    "book",
    "marker",
    "brick",
}
MASS_NOUNS = {
    "electronics",
    "fruit",
    "food",
    "produce",
    "cutlery",
    "tableware",
    "dishware",
    "stuff",
    "everything",
    "grocery",
    "groceries",
}  # plural in meaning
NOT_PLURAL = {"glasses", "eyeglasses", "electronics", "scissors", "pliers", "rubiks", "tongs", "snips"}
RELATIONS: list[tuple[str, str]] = [  # (pattern of tokens, kind), the longer first
    ("to the left of", "left_of"), ("on the left of", "left_of"), ("left of", "left_of"),
    ("to the right of", "right_of"), ("on the right of", "right_of"), ("right of", "right_of"),
    ("in front of", "in_front_of"), ("in back of", "behind"), ("behind", "behind"),
    ("next to", "next_to"), ("beside", "next_to"), ("alongside", "next_to"),
    ("in the center of", "center"), ("in the centre of", "center"), ("in the middle of", "center"),
    ("at the center of", "center"), ("at the centre of", "center"), ("to the center of", "center"),
    ("to the centre of", "center"), ("to the middle of", "center"),
    ("right side up", "upright"), ("upright", "upright"), ("on its base", "upright"), ("on their bases", "upright"),
    ("on top of", "on"), ("onto", "on"), ("on", "on"),
    ("into", "in"), ("inside", "in"), ("in", "in"),
    ("out of", "out"), ("off of", "out"), ("off", "out"), ("away from", "out"), ("from", "out"),
    ("pick up", "pick"), ("lift", "pick"), ("grab", "pick"), ("grasp", "pick"), ("raise", "pick"),
    ("hold up", "pick"), ("pick", "pick"),
    ("stack", "stack"), ("throw away", "away"), ("put away", "away"), ("away", "away"), ("recycle", "away"),
    ("discard", "away"), ("pack", "away"), ("clear", "clear"), ("to", "to"),
]  # fmt: skip
REFERENCED = {"left_of", "right_of", "in_front_of", "behind", "next_to", "on", "in", "out", "to", "clear"}
SPATIAL = {"left_of", "right_of", "in_front_of", "behind", "next_to", "center"}


@dataclass
class SceneObject:
    """A scene object as the reader sees it: its names' words, catalog class, colours, size and place."""

    name: str
    asset: str
    entry: CatalogObject
    xy: tuple[float, float]
    on: str | None
    words: set[str] = field(default_factory=set)

    @property
    def colours(self) -> tuple[str, ...]:
        return self.entry.colors

    @property
    def volume(self) -> float:
        dims = self.entry.dimensions
        return float(dims[0] * dims[1] * dims[2])

    def named(self, word: str) -> bool:
        """Whether a word is part of its catalog or scene name ("red" of red_onion, whose colours are purple)."""
        return word in re.split(r"[_\d]+", self.asset) or word in re.split(r"[_\d]+", self.name)

    def noun(self) -> str:
        """How an instruction names it: the words of its catalog name without colours and sizes, the head noun
        last ("mug", "clay plate", "spring clamp")."""
        words = [p for p in re.split(r"[_\d]+", self.asset) if len(p) > 1]
        parts = [p for p in words if p not in self.colours and p not in MODIFIERS] or words[:1]
        if len(parts) > 1 and parts[0] in HEAD_NOUNS:
            parts = parts[1:] + parts[:1]
        text = " ".join(parts) or self.entry.object_class
        return text.replace("rubiks", "Rubik's").replace("bbq", "barbecue")

    def described(self) -> str:
        """Its colour and noun: "red mug", for the specific instruction."""
        colour = self.colours[0].replace("_", " ") if self.colours and len(self.colours) < 4 else ""
        noun = self.noun()
        return f"{colour} {noun}".strip() if colour and colour not in noun else noun


def rests_in(obj: SceneObject, host: SceneObject) -> bool:
    """Whether a scene object starts on or in another: it rests on it, or stands inside a container's (or a
    shelf's) outline."""
    if obj.name == host.name:
        return False
    if obj.on == host.name:
        return True
    half = max(float(host.entry.dimensions[0]), float(host.entry.dimensions[1])) / 2
    return (
        (obj.xy[0] - host.xy[0]) ** 2 + (obj.xy[1] - host.xy[1]) ** 2 < half**2
        and obj.on is None
        and (host.entry.is_container or host.entry.is_fixture)
    )


@dataclass
class Mention:
    """A noun phrase of the instruction and the scene objects it can mean."""

    start: int
    end: int
    text: str
    candidates: list[str]  # after colour, size and position words
    noun_candidates: list[str]  # the noun alone (for saying why an object does not fit)
    colours: list[str] = field(default_factory=list)
    quantity: str = "the"  # the | all | any | count
    count: int | None = None
    plural: bool = False
    category: bool = False  # named by a class or category word ("fruit", "tools", "items")
    size: int = 0  # +1 bigger, -1 smaller
    position: str | None = None
    excluded: list[str] = field(default_factory=list)  # "the tools that are not hammers"
    modifiers: list[str] = field(default_factory=list)  # "wooden", "square": words of the object's name
    other: bool = False  # "the other tools": those no earlier part of the instruction took
    descriptor: bool = False  # "with the bagels": describes the mention before it, moves nothing

    def wanted(self) -> int | None:
        """How many of the candidates the instruction asks for (None: all of them)."""
        if self.count is not None:
            return self.count
        if self.quantity == "all" or (self.plural and self.quantity == "the"):
            return None
        return 1


@dataclass
class Action:
    """A relation word of the instruction, the mentions it moves and the one it refers to."""

    kind: str  # left_of right_of in_front_of behind next_to center upright on in out pick stack away clear to
    word: str
    position: int
    targets: list[Mention] = field(default_factory=list)
    reference: Mention | None = None
    table_reference: bool = False  # "... on the table", "the centre of the table"
    alternatives: bool = False  # the targets are joined by "or"
    after_then: bool = False  # the action follows "then"


@dataclass
class Reading:
    """What the reader understood of an instruction."""

    text: str
    mentions: list[Mention]
    actions: list[Action]
    missing: list[str]  # words naming catalog objects the scene does not have
    colour_words: list[str]
    size_words: list[str]
    ordered: bool  # "then", "first", "after that"

    def main(self) -> Action | None:
        """The action a single condition expresses: the first one that moves something, with a reference that
        is not the table when there is one."""
        moving = [a for a in self.actions if a.targets or a.kind in ("clear",)]
        for action in moving:
            if action.reference is not None or action.kind in ("pick", "upright", "stack", "center", "away"):
                return action
        return moving[0] if moving else None


def singulars(word: str) -> list[str]:
    """The word and the singular forms it may have ("dishes" -> dish, dishe; "boxes" -> box)."""
    forms = [word, singular(word)]
    if word.endswith("ies") and len(word) > 4:
        forms.append(word[:-3] + "y")
    if word.endswith("es") and len(word) > 3:
        forms.append(word[:-2])
    if word.endswith("s") and not word.endswith("ss") and len(word) > 2:
        forms.append(word[:-1])
    return list(dict.fromkeys(forms))


def plural_word(word: str) -> bool:
    return word not in NOT_PLURAL and word.endswith("s") and not word.endswith("ss") and len(singulars(word)) > 1


def normalise(text: str) -> str:
    text = text.lower().replace("’", "'")
    text = re.sub(r"(\w)'s\b", r"\1s", text)
    text = text.replace("-", " ").replace("gray", "grey").replace("centre", "center")
    return text


def tokens_of(text: str) -> list[str]:
    return re.findall(r"\d+|[a-z]+|[,.;:]", normalise(text))


class SceneVocabulary:
    """The words that name each scene object, and the catalog's words for objects the scene lacks."""

    def __init__(self, scene: SceneSpec, catalog: Catalog) -> None:
        self.scene = scene
        self.catalog = catalog
        self.colours = sorted({c for n in catalog.names() for c in catalog[n].colors} | {"grey"})
        self.objects: dict[str, SceneObject] = {}
        for placement in scene.objects:
            entry = catalog[placement.asset]
            obj = SceneObject(placement.name, placement.asset, entry, placement.xy, placement.on)
            for source in (placement.asset, placement.name):
                parts = [p for p in re.split(r"[_\d]+", source) if p and p not in STATE_WORDS]
                nouns = [
                    p
                    for p in parts
                    if p.isalpha() and len(p) > 2 and p not in self.colours and p not in STOP and p not in MODIFIERS
                ]
                if not nouns:  # "orange_01": a colour word is the noun
                    nouns = [p for p in parts if p.isalpha() and len(p) > 2]
                obj.words.update(nouns)
                obj.words.update(
                    " ".join(parts[i : i + 2])
                    for i in range(len(parts) - 1)
                    if parts[i] in nouns and parts[i + 1] in nouns
                )
            if entry.object_class not in CATEGORIES:  # "furniture": a class word that is no category
                obj.words.add(entry.object_class)
            if entry.is_fixture:
                obj.words.update({"shelf", "rack", "shelving"})
            self.objects[placement.name] = obj
        self.catalog_words: set[str] = set()
        for name in catalog.names():
            parts = [p for p in re.split(r"[_\d]+", name) if p]
            self.catalog_words.update(
                p
                for p in parts
                if p.isalpha() and len(p) > 3 and p not in self.colours and p not in STOP and p not in MODIFIERS
            )

    def movable(self) -> list[str]:
        return [name for name, obj in self.objects.items() if not obj.entry.is_fixture]

    def lookup(self, phrase: str) -> tuple[list[str], bool] | None:
        """The scene objects a noun phrase names, and whether it is a category word; None when it names none."""
        words = phrase.split()
        variants = [" ".join(words[:-1] + [form]) for form in singulars(words[-1])]
        for variant in list(variants):
            last = variant.split()[-1]
            for table in (SYNONYMS, MORE_SYNONYMS):
                if last in table:
                    variants.append(" ".join(variant.split()[:-1] + [table[last]]))
        named: list[str] = []
        for variant in variants:
            named = [name for name, obj in self.objects.items() if variant in obj.words]
            if named:
                break
        for variant in variants:
            key = variant if len(variant.split()) == 1 else None
            if key in CATEGORIES:  # "toys": the toy elephants and every object of the class (blocks included)
                classes, name_words = CATEGORIES[key]
                members = [
                    name
                    for name, obj in self.objects.items()
                    if not obj.entry.is_fixture and (obj.entry.object_class in classes or obj.words & set(name_words))
                ]
                found = named + [name for name in members if name not in named]
                return found, len(found) > len(named)
            if key in GENERIC:
                return self.movable(), True
        return (named, False) if named else None

    def names_catalog_object(self, word: str) -> bool:
        return any(
            form in self.catalog_words or SYNONYMS.get(form, "") in self.catalog_words for form in singulars(word)
        )


def read_instruction(
    text: str, scene: SceneSpec, catalog: Catalog, vocabulary: SceneVocabulary | None = None
) -> Reading:
    """Read an instruction against a scene (see the module's docstring)."""
    vocabulary = vocabulary or SceneVocabulary(scene, catalog)
    tokens = tokens_of(text)
    mentions, missing, colour_words, size_words = _mentions(tokens, vocabulary)
    actions = _actions(tokens, mentions, vocabulary)
    ordered = bool({"then", "first", "after"} & set(tokens))
    return Reading(text, mentions, actions, missing, colour_words, size_words, ordered)


# ------------------------------------------------------------------------------------------------ mentions
def _mentions(tokens: list[str], vocab: SceneVocabulary) -> tuple[list[Mention], list[str], list[str], list[str]]:
    mentions: list[Mention] = []
    missing: list[str] = []
    colour_words: list[str] = []
    size_words: list[str] = []
    pending: list[tuple[int, list[str]]] = []  # "the yellow and the white objects": colours waiting for a noun
    relation_words = _relation_spans(tokens)
    index = 0
    while index < len(tokens):
        start = index
        quantity, count, other = "the", None, False
        while index < len(tokens):
            word = tokens[index]
            if word in ALL_WORDS:
                quantity, count = "all", (2 if word == "both" else count)
            elif word in ANY_WORDS:
                quantity = "any"
            elif word in NUMBER_WORDS or word.isdigit():
                quantity, count = "count", NUMBER_WORDS.get(word) or int(word)
            elif word in ("of", "more") and index > start and (quantity != "the" or count):  # "two of the mugs"
                pass
            elif word in DETERMINERS:
                other = other or word == "other"
            else:
                break
            index += 1
        colours, modifiers, size, position = [], [], 0, None
        while index < len(tokens) and index not in relation_words:
            word = tokens[index]
            if word in vocab.colours and _noun_at(tokens, index, vocab, colour_noun=False) is None:
                colours.append(word)
            elif word in SIZE_WORDS:
                size = SIZE_WORDS[word]
                size_words.append(word)
            elif word in POSITION_WORDS:
                position = word
            elif word in ADJECTIVES and _noun_at(tokens, index, vocab) is None:
                modifiers.append(word)
            else:
                break
            index += 1
        found = _noun_at(tokens, index, vocab)
        if found is None and colours and vocab.lookup(colours[-1]) is not None:  # "an orange": the colour is the noun
            index -= 1
            colours.pop()
            found = _noun_at(tokens, index, vocab)
        if found is None and colours and index < len(tokens) and tokens[index] in ("and", "or"):
            pending.append((start, colours))
            index += 1
            continue
        if found is None:
            if (
                index < len(tokens)
                and tokens[index].isalpha()
                and tokens[index] not in STOP
                and index not in relation_words
                and vocab.names_catalog_object(tokens[index])
                and tokens[index - 1 : index] != ["for"]
            ):
                missing.append(tokens[index])
            index = start + 1 if index == start else index
            continue
        length, candidates, category = found
        # "the toy animals", "the barbecue sauce bottles": nouns in a row name one object, the last is the head
        while index + length < len(tokens) and index + length not in relation_words:
            head = _noun_at(tokens, index + length, vocab)
            if head is None:
                break
            both = [c for c in head[1] if c in candidates]
            candidates, category = (both or head[1]), (category and head[2])
            length += head[0]
        phrase = " ".join(tokens[start : index + length])
        last = tokens[index + length - 1]
        group = [(start, colours)] + pending
        pending = []
        made = []
        for mention_start, mention_colours in group:
            colour_words.extend(mention_colours)
            made.append(
                Mention(
                    start=mention_start,
                    end=index + length,
                    text=phrase,
                    candidates=list(candidates),
                    noun_candidates=list(candidates),
                    colours=list(mention_colours),
                    quantity=quantity,
                    count=count,
                    category=category,
                    plural=plural_word(last) or last in MASS_NOUNS,
                    size=size,
                    position=position,
                    modifiers=modifiers,
                    other=other,
                    descriptor=start > 0 and tokens[start - 1] == "with",
                )
            )
        mentions.extend(made)
        index += length
        # "the tools that are not hammers", "the tools except the hammers"
        rest = tokens[index : index + 4]
        for lead in (
            ["that", "are", "not"],
            ["that", "is", "not"],
            ["except"],
            ["but", "not"],
            ["other", "than"],
            ["not"],
        ):
            if rest[: len(lead)] == lead:
                skip = index + len(lead)
                while skip < len(tokens) and tokens[skip] in ("the", "a", "an"):
                    skip += 1
                excluded = _noun_at(tokens, skip, vocab)
                if excluded is not None:
                    for mention in made:
                        mention.excluded = excluded[1]
                    index = skip + excluded[0]
                break
        # "the holder on the right"
        if (
            tokens[index : index + 3] in (["on", "the", "right"], ["on", "the", "left"])
            and _noun_at(tokens, index + 3, vocab) is None
        ):
            for mention in made:
                mention.position = tokens[index + 2]
            index += 3
    for mention in mentions:
        _narrow(mention, vocab)
    for number, mention in enumerate(mentions):  # "the plate with the bagels": the plate near the bagels
        if mention.descriptor and number > 0:
            _narrow_by_neighbour(mentions[number - 1], mention, vocab)
    return mentions, missing, colour_words, size_words


def _relation_spans(tokens: list[str]) -> set[int]:
    """Token positions where a relation phrase starts ("left" of "to the left of" is not a position adjective)."""
    starts = set()
    for index in range(len(tokens)):
        for pattern, _ in RELATIONS:
            words = pattern.split()
            if tokens[index : index + len(words)] == words and len(words) > 1:
                starts.update(range(index, index + len(words)))
    return starts


def _noun_at(
    tokens: list[str], index: int, vocab: SceneVocabulary, colour_noun: bool = True
) -> tuple[int, list[str], bool] | None:
    """The longest phrase at `index` (up to three words) that names scene objects: (length, objects, category).
    With `colour_noun` False, a one-word colour ("orange") counts only when it is followed by no other noun."""
    for length in (3, 2, 1):
        words = tokens[index : index + length]
        if len(words) < length or any(not w.isalpha() or w in STOP or w in ("and", "or", "then") for w in words):
            continue
        if not colour_noun and length == 1 and words[0] in vocab.colours:
            following = _noun_at(tokens, index + 1, vocab) if index + 1 < len(tokens) else None
            if following is not None or tokens[index + 1 : index + 2] in (["and"], ["or"]):
                continue
        found = vocab.lookup(" ".join(words))
        if found is not None:
            return length, found[0], found[1]
    return None


def _narrow(mention: Mention, vocab: SceneVocabulary) -> None:
    """Apply the mention's colour, size, position and exclusion words to its candidates."""
    objects = vocab.objects
    candidates = [c for c in mention.candidates if c not in mention.excluded]
    for word in mention.modifiers:
        stem = word[:-2] if word.endswith("en") else word  # wooden -> wood
        named = [c for c in candidates if stem in c or stem in objects[c].asset]
        candidates = named or candidates
    for colour in mention.colours:
        first = [c for c in candidates if objects[c].colours[:1] == (colour,) or objects[c].named(colour)]
        anywhere = [
            c
            for c in candidates
            if colour in objects[c].colours and len(objects[c].colours) < 4 or objects[c].named(colour)
        ]
        candidates = first if mention.category and first else anywhere or first
    if mention.size and candidates:
        ordered = sorted(candidates, key=lambda c: objects[c].volume * mention.size, reverse=True)
        if mention.plural:
            mean = sum(objects[c].volume for c in candidates) / len(candidates)
            candidates = [c for c in candidates if (objects[c].volume - mean) * mention.size > 0]
        else:
            candidates = ordered[:1]
    if mention.position and len(candidates) > 1:
        axis, sign = POSITION_WORDS[mention.position]
        candidates = [max(candidates, key=lambda c: objects[c].xy[axis] * sign)]
    mention.candidates = candidates


def _narrow_by_neighbour(mention: Mention, descriptor: Mention, vocab: SceneVocabulary) -> None:
    """Keep the candidate of `mention` nearest the objects of `descriptor` ("the plate with the bagels")."""
    if len(mention.candidates) < 2 or not descriptor.candidates:
        return
    objects = vocab.objects

    def distance(name: str) -> float:
        x, y = objects[name].xy
        return min((x - objects[d].xy[0]) ** 2 + (y - objects[d].xy[1]) ** 2 for d in descriptor.candidates)

    mention.candidates = [min(mention.candidates, key=distance)]


# ------------------------------------------------------------------------------------------------ actions
def _actions(tokens: list[str], mentions: list[Mention], vocab: SceneVocabulary) -> list[Action]:
    inside = [(m.start, m.end) for m in mentions]
    found: list[Action] = []
    index = 0
    while index < len(tokens):
        match = None
        for pattern, kind in RELATIONS:
            words = pattern.split()
            if tokens[index : index + len(words)] == words:
                match = (pattern, kind, len(words))
                break
        if match is None or any(start <= index < end for start, end in inside):
            index += 1
            continue
        found.append(Action(kind=match[1], word=match[0], position=index))
        index += match[2]
    movers = [m for m in mentions if not m.descriptor]
    # references: the first mention after a relation phrase, or the table
    for number, action in enumerate(found):
        end = action.position + len(action.word.split())
        following = found[number + 1].position if number + 1 < len(found) else len(tokens)
        after = [m for m in movers if end <= m.start < following]
        if action.kind == "center":
            action.table_reference = True
        elif action.kind in REFERENCED:
            gap = tokens[end : after[0].start] if after else tokens[end:following]
            if "table" in gap[:3]:
                action.table_reference = True
            elif after and action.kind != "clear":
                action.reference = after[0]
    # targets: the mentions between the previous action's reference (or a colon) and the relation phrase
    boundary = 0
    claimed: set[int] = set()
    for action in found:
        for stop in (":", ";", "."):
            if stop in tokens[boundary : action.position]:
                boundary = max(i for i in range(boundary, action.position) if tokens[i] == stop) + 1
        before = [
            m
            for m in movers
            if boundary <= m.start < action.position and id(m) not in claimed and m is not action.reference
        ]
        action.after_then = (
            "then" in tokens[boundary : action.position] or "then" in tokens[max(0, boundary - 3) : boundary]
        )
        action.targets = before
        claimed.update(id(m) for m in before)
        if action.reference is not None:
            claimed.add(id(action.reference))
            boundary = action.reference.end
        elif action.targets or action.table_reference:
            boundary = action.position + len(action.word.split())
    # verbs before their objects: "pick up A", "stack A and B", "clear A", "throw away A", "stand A upright"
    for number, action in enumerate(found):
        if action.kind in ("pick", "stack", "away", "clear") and not action.targets:
            end = action.position + len(action.word.split())
            following = found[number + 1].position if number + 1 < len(found) else len(tokens)
            action.targets = [
                m for m in movers if end <= m.start < following and id(m) not in claimed and m is not action.reference
            ]
            if action.kind == "clear" and action.targets:
                action.reference, action.targets = action.targets[0], []
            claimed.update(id(m) for m in action.targets)
    # "stack A on B", "stack all four blocks into a tower": the stack verb takes the relation after it
    for number, action in enumerate(found[:-1]):
        nxt = found[number + 1]
        if action.kind == "stack" and nxt.kind in ("on", "in", "to"):
            nxt.kind, nxt.word = "stack", f"stack ... {nxt.word}"
            if action.targets and not nxt.targets:
                nxt.targets, action.targets = action.targets, []
            if nxt.reference is not None and nxt.reference.candidates and not _is_stackable(nxt, vocab):
                nxt.kind = "in"  # "stack the left bowl on the right bowl": one container into the other
    # "put A in B, then C": mentions after "then" or a comma with no relation of their own take the previous one's
    actions = [a for a in found if a.targets or a.reference is not None or a.table_reference]
    leftover = [m for m in movers if id(m) not in claimed]
    if leftover and actions:
        last = actions[-1]
        tail = [m for m in leftover if m.start > (last.reference.end if last.reference else last.position)]
        between = tokens[(last.reference.end if last.reference else last.position) : tail[0].start] if tail else []
        if tail and last.kind in ("in", "on", "to", "away") and ("then" in between or "," in between):
            actions.append(
                Action(
                    kind=last.kind,
                    word=last.word,
                    position=tail[0].start,
                    targets=tail,
                    reference=last.reference,
                    table_reference=last.table_reference,
                    after_then="then" in between,
                )
            )
    # pronouns: "take the drill out of the bin and put it on the table"
    for number, action in enumerate(actions):
        if not action.targets and number > 0 and action.kind in REFERENCED:
            span = tokens[actions[number - 1].position : action.position]
            if {"it", "them", "one"} & set(span):
                action.targets = actions[number - 1].targets
    # "the other tools": those no earlier action took
    taken: set[str] = set()
    for action in actions:
        for mention in action.targets:
            if mention.other:
                mention.candidates = [c for c in mention.candidates if c not in taken]
        taken.update(c for mention in action.targets for c in mention.candidates)
    for action in actions:
        if len(action.targets) > 1:
            action.alternatives = "or" in tokens[action.targets[0].end : action.targets[-1].start]
    return actions


def _is_stackable(action: Action, vocab: SceneVocabulary) -> bool:
    """Whether "stack A on B" means a tower (blocks, cubes, boxes) rather than one container into another."""
    reference = vocab.objects[action.reference.candidates[0]]
    return not reference.entry.is_container
