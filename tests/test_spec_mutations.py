"""Every shipped task spec and scene file, and a sample of catalog entries, broken one field at a time in many ways:
loading must raise a SpecError naming the file and the broken field, never another exception and never accept it,
unless the mutation is listed below as valid (then it must load)."""

from __future__ import annotations

import copy
import functools
import inspect
import json
import math
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from robolab_ms.catalog import load_catalog, read_catalog
from robolab_ms.catalog.modelled import GENERATORS as MODELLED_GENERATORS
from robolab_ms.catalog.procedural import GENERATORS
from robolab_ms.content import content_dir
from robolab_ms.errors import SpecError
from robolab_ms.scene import read_scene, scene_names
from robolab_ms.tasks.predicates import PREDICATES
from robolab_ms.tasks.spec import read_task, task_names

# Replacement values, tried on every field, list entry and mapping of a file.
VALUES: dict[str, Any] = {
    "nan": float("nan"),
    "inf": float("inf"),
    "negative": -1,
    "zero": 0,
    "huge": 1e9,
    "bool": True,
    "empty_text": "",
    "empty_list": [],
    "unknown_name": "no_such_name",
    "mapping": {"x": 1},
}
# Structural mutations: "missing" leaves a field out, "unknown_key" adds a field no schema knows, "repeated_key"
# gives a field twice, "repeated_entry" repeats the first entry of a list at its end.

# Mutations that leave a valid file, by kind of file: normalized field path (list indices written as []) -> names.
# Everything else must be refused.
TEXT_ANYTHING = {"unknown_name"}  # free text: any non-blank text is fine
OPTIONAL = {"missing"}
VALID: dict[str, dict[str, set[str]]] = {
    "task": {
        "instructions.*": TEXT_ANYTHING,
        "attributes": OPTIONAL | {"empty_list"},
        "subtasks": OPTIONAL | {"repeated_entry"},  # a stage twice is redundant but well defined
        "success": {"repeated_entry"},  # likewise a condition twice
        "subtasks[].steps": {"repeated_entry"},
        "contact_objects": OPTIONAL,
        "events": OPTIONAL,
        "success[].logical": OPTIONAL,
        "success[].require_contact_with": OPTIONAL,
        "success[].require_gripper_detached": OPTIONAL,
        "success[].surface": OPTIONAL,  # default: the table
        "success[].distance": OPTIONAL,
        "success[].tolerance": OPTIONAL,
        "success[].order": OPTIONAL,
        "success[].max_tilt": OPTIONAL,
        "success[].container_max_tilt": OPTIONAL,
        "success[].require_picked_up": OPTIONAL,
        "subtasks[].steps[].weight": OPTIONAL,
        "subtasks[].steps[].require_contact_with": OPTIONAL,
        "subtasks[].steps[].require_gripper_detached": OPTIONAL,
        "subtasks[].steps[].distance": OPTIONAL,
        "subtasks[].steps[].tolerance": OPTIONAL,
        "subtasks[].steps[].max_tilt": OPTIONAL,
        "subtasks[].steps[].surface": OPTIONAL,  # default: the table
    },
    "scene": {
        "description": OPTIONAL | TEXT_ANYTHING,
        "table": OPTIONAL,
        "table.size": OPTIONAL,
        "table.color": OPTIONAL,
        "table.material": OPTIONAL,
        "jitter": OPTIONAL,
        "jitter.xy": OPTIONAL | {"zero"},
        "jitter.yaw_deg": OPTIONAL | {"zero"},
        "objects[].name": OPTIONAL | TEXT_ANYTHING,  # the name defaults to the asset's
        "background": OPTIONAL,
    },
    "catalog": {
        "version": OPTIONAL,
        "objects.*.description": TEXT_ANYTHING,
        "objects.*.license": TEXT_ANYTHING,
        "objects.*.colors": {"repeated_entry"},  # a palette may repeat a colour
        "objects.*.restitution": OPTIONAL | {"zero"},
        "objects.*.fixture": OPTIONAL,  # without it, a dynamic object
        "objects.*.source.textured": OPTIONAL,
        "objects.*.source.package": TEXT_ANYTHING,  # checked by `robolab catalog check`, which loads the meshes
        "objects.*.source.paths[]": TEXT_ANYTHING,  # likewise
        "objects.*.source.collision_pieces": TEXT_ANYTHING,  # a file pattern, matched by `robolab catalog build`
        "objects.*.transform": OPTIONAL,
        "objects.*.transform.rotation_deg": OPTIONAL,
        "objects.*.transform.translation": OPTIONAL,
        "objects.*.transform.scale": OPTIONAL,
        "objects.*.transform.rotation_deg[]": {"zero", "negative"},
        "objects.*.transform.translation[]": {"zero", "negative"},
    },
}
TURNS = {
    "objects[].yaw_deg": {"zero", "negative", "missing"},
    "objects[].tilt": {"missing", "repeated_entry"},
    "objects[].tilt.deg": {"zero", "negative"},
    "objects[].tilt[].deg": {"zero", "negative"},
    "objects[].rests_on": {"missing"},  # -1 degree: a slight turn; without its support, on the table
    "objects[].level": {"zero"},
}  # the lowest board of its fixture, which may leave too little room above
LAYOUT = "layout"  # valid, or refused because objects overlap or leave the table (depends on the other objects)


def matches(pattern: str, path: str) -> bool:
    """`path` (indices written as []) fits `pattern`, where * stands for one field name."""
    return re.fullmatch(re.escape(pattern).replace(r"\*", r"[^.\[\]]+"), normalized(path)) is not None


def normalized(path: str) -> str:
    return re.sub(r"\[\d+\]", "[]", path)


def expectation(kind: str, data: dict, path: str, mutation: str, default: str) -> str | None:
    """None when the mutation leaves a valid file, LAYOUT, or the field the error must name (`default` unless a
    rule below says otherwise)."""
    steps = split(path)
    if kind == "scene" and matches("objects[].name", path) and mutation in ("missing", "unknown_name"):
        renamed = data["objects"][steps[1]].get("name")
        new_name = data["objects"][steps[1]]["asset"] if mutation == "missing" else VALUES["unknown_name"]
        for index, other in enumerate(data["objects"]):
            if index != steps[1] and other.get("name", other["asset"]) == new_name:
                return f"objects[{max(index, steps[1])}].name"  # its default name is another object's: named twice
        for index, other in enumerate(data["objects"]):
            if renamed is not None and renamed != new_name and other.get("rests_on") == renamed:
                return f"objects[{index}].rests_on"  # what rests on it names it by its old name
    if kind == "scene" and matches("objects[].tilt", path) and mutation == "mapping":
        return f"{path}.x"  # a list of turns replaced by a mapping, read as one turn: its key x is unknown
    if kind == "scene" and matches("objects[].rests_on", path) and mutation == "missing":
        if "level" in data["objects"][steps[1]]:
            return f"objects[{steps[1]}].level"  # a level of no fixture
    if kind == "scene" and path in ("jitter", "jitter.xy", "jitter.yaw_deg") and mutation == "missing":
        return LAYOUT  # the default jitter may be larger than the file's, and carry an object past the table's edge
    if any(matches(pattern, path) and mutation in names for pattern, names in VALID[kind].items()):
        return None
    if kind == "task" and matches("subtasks[].logical", path) and mutation == "missing":
        return f"subtasks[{steps[1]}].k" if "k" in data["subtasks"][steps[1]] else None  # k needs logical: choose
    if kind == "task" and matches("subtasks[].steps[].weight", path) and mutation == "zero":
        weights = [step.get("weight", 1) for step in data["subtasks"][steps[1]]["steps"]]
        others = weights[: steps[3]] + weights[steps[3] + 1 :]
        return None if any(others) else f"subtasks[{steps[1]}].steps"  # a stage needs one positive weight
    if kind == "task" and matches("success[].groups.*", path) and mutation == "missing":
        condition = data["success"][steps[1]]
        return None if len(condition["groups"]) > 1 and "objects" not in condition else default  # fewer groups
    if kind == "task" and matches("subtasks[].steps[].groups.*", path) and mutation == "missing":
        return path.rsplit(".", 1)[0]  # the stage's objects left without their group: the error names `groups`
    if kind == "task" and matches("success[].tolerance", path) and mutation == "zero":
        predicate = data["success"][steps[1]]["predicate"]
        return None if PREDICATES[predicate].params["tolerance"] == 0.0 else default  # 0 where it is the default
    if kind == "scene" and matches("objects[].xy[]", path) and mutation == "zero" and steps[-1] == 1:
        return LAYOUT  # y = 0 is on the table; whether it collides depends on the others
    if kind == "scene" and any(matches(pattern, path) and mutation in names for pattern, names in TURNS.items()):
        return LAYOUT  # a valid turn, which may bring the object against a close neighbour
    if kind == "catalog" and len(steps) > 1:
        return catalog_expectation(data["objects"][steps[1]], f"objects.{steps[1]}", path, mutation, default)
    return default


def catalog_expectation(entry: dict, prefix: str, path: str, mutation: str, default: str) -> str | None:
    """The rules for a catalog entry that depend on its kind: procedural objects derive their size, interior and
    collision from their generator, whose parameters with defaults may be left out."""
    procedural = entry["source"]["kind"] == "procedural"
    modelled = entry["source"]["kind"] == "modelled"
    field = path[len(prefix) + 1 :]
    if field == "" and mutation == "missing":
        return "objects"  # the sample catalog is left without objects
    if field == "colors" and mutation == "empty_list":
        return None if "rgba" in entry else default
    if field == "container" and mutation == "missing":
        return f"{prefix}.interior" if "interior" in entry else None  # an interior needs container: true
    if field == "interior" and mutation == "missing" and modelled:
        return None  # a modelled container's interior comes from its generator, as a procedural one's
    if field == "shape" and mutation == "missing":
        return None if procedural or modelled else default  # a generated object is primitive unless it says modelled
    if field in ("interior", "dimensions", "collision", "collision.method") and mutation == "missing":
        return None if procedural else f"{prefix}.{field.split('.')[0]}" + (".method" if "collision" in field else "")
    if not (procedural or modelled) or not field.startswith("source.params"):
        return default
    generators = GENERATORS if procedural else MODELLED_GENERATORS
    signature = inspect.signature(generators[entry["source"]["generator"]]).parameters
    if field == "source.params" and mutation == "missing":
        required = [key for key, parameter in signature.items() if parameter.default is inspect.Parameter.empty]
        return f"{path}.{required[0]}" if required else None
    parameter = signature.get(field[len("source.params.") :])
    if parameter is None:
        return default
    if mutation == "missing":
        return None if parameter.default is not inspect.Parameter.empty else default
    if mutation == "zero":  # a length whose default is 0 means none
        return None if parameter.default == 0.0 and str(parameter.annotation) == "float" else default
    if mutation == "bool":
        return None if str(parameter.annotation) == "bool" else default
    return default


class Twice(str):
    """A mapping key written a second time: equal only to itself, so that a dict holds it beside the first."""

    __hash__ = object.__hash__

    def __eq__(self, other: object) -> bool:
        return self is other


def yaml_float(value: float) -> str:
    """A float as YAML 1.1 reads it back as a float (it wants a dot in the mantissa and a signed exponent)."""
    if not math.isfinite(value):
        return ".nan" if math.isnan(value) else ".inf" if value > 0 else "-.inf"
    text = repr(value)
    if "e" in text:
        mantissa, exponent = text.split("e")
        mantissa = mantissa if "." in mantissa else mantissa + ".0"
        text = f"{mantissa}e{'' if exponent[0] in '+-' else '+'}{exponent}"
    return text


def dump(data: Any) -> bytes:
    """`data` as YAML text: JSON (a subset of YAML) with floats spelled as YAML 1.1 reads them."""

    def marked(value: Any) -> Any:
        if isinstance(value, float):
            return f"@@{yaml_float(value)}@@"
        if isinstance(value, dict):
            return {key: marked(item) for key, item in value.items()}
        if isinstance(value, list):
            return [marked(item) for item in value]
        return value

    return re.sub(r'"@@([^@"]*)@@"', r"\1", json.dumps(marked(data), ensure_ascii=False)).encode()


def nodes(data: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    """Every field path in `data` (dotted, with [i] for list entries) and its value."""
    if isinstance(data, dict):
        for key, value in data.items():
            child = f"{path}.{key}" if path else str(key)
            yield child, value
            yield from nodes(value, child)
    elif isinstance(data, list):
        for index, value in enumerate(data):
            child = f"{path}[{index}]"
            yield child, value
            yield from nodes(value, child)


def split(path: str) -> list[str | int]:
    return [int(part) if part.isdigit() else part for part in re.findall(r"[^.\[\]]+", path)]


def parent_and_key(data: Any, path: str) -> tuple[Any, str | int]:
    steps = split(path)
    for step in steps[:-1]:
        data = data[step]
    return data, steps[-1]


def mutate(data: dict, path: str, mutation: str) -> tuple[dict, str] | None:
    """`data` with the field at `path` broken by `mutation`, and the field the error must name (None when the
    mutation does not apply to that field)."""
    mutated = copy.deepcopy(data)
    parent, key = parent_and_key(mutated, path)
    value = parent[key]
    if mutation in VALUES:
        if VALUES[mutation] == value and type(VALUES[mutation]) is type(value):
            return None
        parent[key] = copy.deepcopy(VALUES[mutation])
        return mutated, path
    if mutation == "missing" and isinstance(parent, dict):
        del parent[key]
        return mutated, path
    if mutation == "repeated_key" and isinstance(parent, dict):
        parent[Twice(key)] = copy.deepcopy(value)
        return mutated, path
    if mutation == "unknown_key" and isinstance(value, dict):
        value["no_such_field"] = 1
        return mutated, f"{path}.no_such_field"
    if mutation == "repeated_entry" and isinstance(value, list) and value:
        value.append(copy.deepcopy(value[0]))
        return mutated, f"{path}[{len(value) - 1}]"
    return None


MUTATIONS = [*VALUES, "missing", "repeated_key", "unknown_key", "repeated_entry"]
LATER_OCCURRENCE_MUTATIONS = 2


def field_kind(kind: str, path: str) -> str:
    """What counts as the same field: list indices and (in the catalog) object names do not matter."""
    path = normalized(path)
    return re.sub(r"^objects\.[^.\[]+", "objects.*", path) if kind == "catalog" else path


def mutations(kind: str, data: dict, fully: frozenset[str], turn: int) -> Iterator[tuple[str, str, dict, str]]:
    """(mutated path, mutation, mutated data, field the error must name). Fields of a kind in `fully` (the first
    file that has them) are broken in every way at their first occurrence; the others in two ways each, taken in
    turn (`turn` shifts the choice from file to file), so every field of every file is broken and the run stays
    short."""
    seen: dict[str, int] = {}
    for path, _ in list(nodes(data)):
        kind_of_field = field_kind(kind, path)
        occurrence = seen[kind_of_field] = seen.get(kind_of_field, -1) + 1
        applicable = [(name, result) for name in MUTATIONS if (result := mutate(data, path, name)) is not None]
        if occurrence or kind_of_field not in fully:
            start = (occurrence + turn) * LATER_OCCURRENCE_MUTATIONS
            applicable = [
                applicable[(start + i) % len(applicable)]
                for i in range(min(LATER_OCCURRENCE_MUTATIONS, len(applicable)))
            ]
        for name, (mutated, expected) in applicable:
            yield path, name, mutated, expected


def field_matches(field: str, expected: str, mutation: str, was_mapping: bool) -> bool:
    """The error names the broken field: itself, the list it is an entry of, a field of a mapping replaced by
    another mapping, or a field of a repeated entry."""
    if field == expected or (expected.endswith("]") and field == re.sub(r"\[\d+\]$", "", expected)):
        return True
    if mutation == "mapping" and was_mapping:
        return field.startswith(expected + ".") and "." not in field[len(expected) + 1 :]
    return mutation == "repeated_entry" and field.startswith(expected + ".")


def run_mutations(kind: str, name: str, data: dict, file: Path, load: Callable[[Path], Any]) -> list[str]:
    """Load the mutations of file `name` (content `data`), each written to `file`; the list of wrong outcomes."""
    problems = []
    originals = dict(nodes(data))
    names = FILES[kind]()
    for path, mutation, mutated, default in mutations(kind, data, fully_broken_in(kind, name), names.index(name)):
        file.unlink(missing_ok=True)  # a new file: much faster than truncating the old one on some file systems
        file.write_bytes(dump(mutated))
        expected = expectation(kind, data, path, mutation, default)
        try:
            load(file)
        except SpecError as error:
            where = f"{path} {mutation}: "
            if error.file != str(file) or str(file) not in str(error):
                problems.append(f"{where}the error does not name the file: {error}")
            elif expected is None:
                problems.append(f"{where}refused although valid: {error}")
            elif expected == LAYOUT:
                if not (
                    matches("objects[].xy", error.field)
                    and any(word in error.problem for word in ("overlaps", "table", "support", "level"))
                ):
                    problems.append(f"{where}refused, but not for the layout: {error}")
            elif not field_matches(error.field, expected, mutation, isinstance(originals[path], dict)):
                problems.append(f"{where}the error names field '{error.field}', not '{expected}': {error}")
        except Exception as error:  # noqa: BLE001 - any other exception is what this test exists to catch
            problems.append(f"{path} {mutation}: {type(error).__name__} instead of SpecError: {error}")
        else:
            if expected is not None and expected != LAYOUT:
                problems.append(f"{path} {mutation}: accepted")
    return problems


def file_level_problems(data: dict, file: Path, load: Callable[[Path], Any]) -> list[str]:
    """A byte that is not UTF-8 (in a comment on line 2), and the unmutated file, which must load."""
    problems = []
    file.write_bytes(dump(data))
    load(file)  # the unmutated, re-written file loads: the mutations start from a valid file
    lines = dump(data).split(b"\n")
    file.write_bytes(b"\n".join([lines[0], b"# caf\xe9", *lines[1:]]))
    try:
        load(file)
        problems.append("non-UTF-8 byte: accepted")
    except SpecError as error:
        if error.file != str(file) or error.field != "line 2" or "UTF-8" not in str(error):
            problems.append(f"non-UTF-8 byte: unclear error {error}")
    return problems


def read_shipped(kind: str, name: str) -> dict:
    """The shipped file's content; for the catalog, a catalog of the one entry `name`."""
    if kind == "catalog":
        return {"version": CATALOG["version"], "objects": {name: CATALOG["objects"][name]}}
    folder = {"task": "tasks", "scene": "scenes"}[kind]
    return yaml.safe_load((content_dir(folder) / f"{name}.yaml").read_text(encoding="utf-8"))


def catalog_sample() -> list[str]:
    """The first entry of each procedural and each modelled generator and of each mesh collision method (in name
    order)."""
    catalog = load_catalog()
    chosen: dict[str, str] = {}
    for name in catalog.names():
        entry = catalog[name]
        if entry.is_procedural or entry.is_modelled:
            group = f"{entry.source['kind']} {entry.source['generator']}"
        else:
            group = entry.collision_method
        chosen.setdefault(group, name)
    return sorted(chosen.values())


CATALOG = yaml.safe_load((content_dir("assets") / "catalog.yaml").read_text(encoding="utf-8"))
FILES: dict[str, Callable[[], list[str]]] = {"task": task_names, "scene": scene_names, "catalog": catalog_sample}


@functools.cache
def fully_broken_in(kind: str, name: str) -> frozenset[str]:
    """The kinds of field that file `name` is the first (in name order) to have: it breaks them in every way."""
    seen: set[str] = set()
    for other in FILES[kind]():
        fields = {field_kind(kind, path) for path, _ in nodes(read_shipped(kind, other))}
        if other == name:
            return frozenset(fields - seen)
        seen |= fields
    raise KeyError(name)


@pytest.fixture()
def scenes_read_once(monkeypatch):
    """Task files name shipped scenes, which the scene test breaks on their own: read each one once here."""
    from robolab_ms.tasks import spec

    monkeypatch.setattr(spec, "load_scene", functools.lru_cache(maxsize=None)(spec.load_scene))


@pytest.mark.parametrize("name", task_names())
def test_every_broken_field_of_a_task_spec_is_reported(tmp_path, name, scenes_read_once):
    data = read_shipped("task", name)
    file = tmp_path / f"{name}.yaml"
    problems = file_level_problems(data, file, read_task)
    problems += run_mutations("task", name, data, file, read_task)
    assert not problems, f"{len(problems)} wrong outcomes:\n" + "\n".join(problems)


@pytest.mark.parametrize("name", scene_names())
def test_every_broken_field_of_a_scene_is_reported(tmp_path, name):
    data = read_shipped("scene", name)
    file = tmp_path / f"{name}.yaml"
    problems = file_level_problems(data, file, read_scene)
    problems += run_mutations("scene", name, data, file, read_scene)
    assert not problems, f"{len(problems)} wrong outcomes:\n" + "\n".join(problems)


@pytest.mark.parametrize("name", catalog_sample())
def test_every_broken_field_of_a_catalog_entry_is_reported(tmp_path, name):
    data = read_shipped("catalog", name)
    file = tmp_path / "catalog.yaml"
    problems = file_level_problems(data, file, read_catalog)
    problems += run_mutations("catalog", name, data, file, read_catalog)
    assert not problems, f"{len(problems)} wrong outcomes:\n" + "\n".join(problems)


BROKEN_SCENE = """name: broken_scene
objects: [{asset: banana, xy: [0.5, 0.1]}, {asset: bowl_white, xy: [0.55, -0.15]}]
"""
BROKEN_TASK = """name: Broken
scene: broken_scene.yaml
episode_seconds: 0.05
instructions: {default: a, vague: b, specific: c}
success:
  - {predicate: in_container, objects: [banana], container: bowl_white}
"""


def test_a_broken_task_file_is_refused_however_it_arrives(tmp_path, capsys):
    """gym.make(..., task=path) and the CLI's list, validate and eval all read the file through read_task."""
    import gymnasium as gym

    import robolab_ms.envs  # noqa: F401  (registers the RoboLab ids)
    from robolab_ms.cli import main

    (tmp_path / "broken_scene.yaml").write_text(BROKEN_SCENE)
    path = tmp_path / "Broken.yaml"
    path.write_text(BROKEN_TASK)
    with pytest.raises(SpecError) as error:
        gym.make("RoboLab-BananaInBowl-v1", task=str(path))
    assert error.value.file == str(path) and error.value.field == "episode_seconds"
    assert "shorter than one control step" in str(error.value)
    for command in (["list"], ["validate"], ["eval", "--policy", "oracle", "--out", str(tmp_path / "out")]):
        assert main([*command, "--task", str(path)]) == 2, command
        printed = capsys.readouterr().err
        assert f"{path}: field 'episode_seconds'" in printed and "Traceback" not in printed, (command, printed)


PILE_SCENE = """name: pile
objects:
  - {{name: bottom, asset: rubiks_cube, xy: [0.5, 0.0]}}
  - {{name: top, asset: rubiks_cube, xy: [{top_x}, 0.0], rests_on: {top_on}}}
  - {{name: bin, asset: grey_bin, xy: [0.5, -0.3]}}
"""


@pytest.mark.parametrize(
    ("top_x", "top_on", "field", "problem"),
    [
        (0.5, "botom", "objects[1].rests_on", "Did you mean 'bottom'"),  # a typo
        (0.5, "table", "objects[1].rests_on", "names the table"),  # the table is every object's support already
        (0.5, "top", "objects[1].rests_on", "cannot rest on itself"),
        (0.7, "bottom", "objects[1].xy", "is not over its support 'bottom'"),  # beside it, not on it
        (0.5, "[bottom]", "objects[1].rests_on", "must be a text"),
    ],
)
def test_bad_support_names_file_field_and_fix(tmp_path, top_x, top_on, field, problem):
    path = tmp_path / "pile.yaml"
    path.write_text(PILE_SCENE.format(top_x=top_x, top_on=top_on))
    with pytest.raises(SpecError) as error:
        read_scene(path)
    assert error.value.file == str(path) and error.value.field == field, error.value
    assert problem in str(error.value) and error.value.fix, error.value


def test_supports_that_form_a_loop_are_refused(tmp_path):
    path = tmp_path / "pile.yaml"
    path.write_text(
        PILE_SCENE.format(top_x=0.5, top_on="bottom").replace(
            "{name: bottom, asset: rubiks_cube, xy: [0.5, 0.0]}",
            "{name: bottom, asset: rubiks_cube, xy: [0.5, 0.0], rests_on: top}",
        )
    )
    with pytest.raises(SpecError) as error:
        read_scene(path)
    assert error.value.field == "objects[0].rests_on" and "loop (bottom on top on bottom)" in error.value.problem


def test_an_object_that_would_reach_the_table_first_is_refused(tmp_path):
    """A tilted keyboard whose raised end just reaches over a cube: lowered, its other end meets the table first."""
    path = tmp_path / "pile.yaml"
    path.write_text(
        PILE_SCENE.format(top_x=0.5, top_on="bottom").replace(
            "{name: top, asset: rubiks_cube, xy: [0.5, 0.0], rests_on: bottom}",
            "{name: top, asset: keyboard_low, xy: [0.5, 0.2], tilt: {axis: x, deg: -30}, rests_on: bottom}",
        )
    )
    with pytest.raises(SpecError, match="would rest on the table before it touches its support 'bottom'") as error:
        read_scene(path)
    assert error.value.field == "objects[1].xy"
