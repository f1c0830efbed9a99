"""Task specs: one YAML file per task in task_specs/, read and checked here.

A task is a scene, three instruction variants, one or more success conditions (any one suffices), its attributes,
and optionally subtasks (stages of weighted steps), the objects whose contacts matter for events, and event
thresholds. Without `subtasks`, they are derived from the first success condition: for each of its objects,
"grasped" (weight 0) then the condition itself (weight 1), combined by the condition's logical (all / any / choose K).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robolab_ms.content import Fields, check_name, content_files, load_yaml
from robolab_ms.errors import RoboLabError, UnknownNameError, did_you_mean
from robolab_ms.scene import SceneSpec, load_scene, read_scene, scene_names
from robolab_ms.tasks.condition import Condition
from robolab_ms.tasks.events import EVENT_THRESHOLDS
from robolab_ms.tasks.predicates import FLAGS, PREDICATES, STACK_ORDERS, TABLE
from robolab_ms.tasks.progress import Group, Stage

CONTROL_HZ = 15
INSTRUCTION_VARIANTS = ("default", "vague", "specific")
AXIS_OF_ATTRIBUTE = {
    "color": "visual", "semantics": "visual", "size": "visual",
    "conjunction": "relational", "counting": "relational", "spatial": "relational",
    "affordance": "procedural", "reorientation": "procedural", "stacking": "procedural", "sorting": "procedural",
    "vague": "instruction",
}  # fmt: skip
SKILL_WEIGHT = {
    "color": 0, "semantics": 0, "size": 0, "conjunction": 0, "vague": 0, "spatial": 1,
    "counting": 2, "sorting": 2, "stacking": 2, "affordance": 2, "reorientation": 3,
}  # fmt: skip
LOGICALS = ("all", "any", "choose")
DIFFICULTIES = ("simple", "moderate", "complex")  # RoboLab's levels, easiest first (TaskSpec.difficulty)
TASK_KEYS = (
    "name",
    "scene",
    "episode_seconds",
    "attributes",
    "instructions",
    "success",
    "subtasks",
    "contact_objects",
    "events",
)  # the keys a task file may have, in the order it lists them


@dataclass(frozen=True)
class SubtaskStage:
    """A stage: one group per object, each group running the same ordered, weighted steps on its own object."""

    objects: tuple[str, ...]
    steps: tuple[Condition, ...]  # each over all of `objects`; group i uses column i
    weights: tuple[float, ...]
    logical: str = "all"
    k: int = 1

    def object_groups(self) -> int:
        """RoboLab's object groups in this stage: a `groups_in_containers` step groups the stage's objects by their
        container (one group per container); otherwise each object is a group of its own."""
        for step in self.steps:
            if "groups" in step.params:
                return sum(1 for members in step.params["groups"].values() if set(members) & set(self.objects))
        return len(self.objects)


@dataclass(frozen=True)
class TaskSpec:
    """A task spec, checked against its scene and the predicate registry."""

    name: str
    scene: SceneSpec
    file: Path
    episode_seconds: float
    attributes: tuple[str, ...]
    instructions: dict[str, str]
    success: tuple[Condition, ...]
    subtasks: tuple[SubtaskStage, ...]
    contact_objects: tuple[str, ...]
    event_thresholds: dict[str, float]

    @property
    def env_id(self) -> str:
        return f"RoboLab-{self.name}-v1"

    @property
    def max_episode_steps(self) -> int:
        return round(self.episode_seconds * CONTROL_HZ)

    @property
    def num_subtasks(self) -> int:
        """Subtasks summed over stages (RoboLab's count): a stage counts its object groups (`all`; see
        SubtaskStage.object_groups), 1 (`any`) or K (`choose`)."""
        return sum({"all": s.object_groups(), "any": 1, "choose": s.k}[s.logical] for s in self.subtasks)

    @property
    def difficulty_score(self) -> int:
        """Number of subtasks plus the largest skill weight among the attributes (RoboLab's rating)."""
        return self.num_subtasks + max((SKILL_WEIGHT[a] for a in self.attributes), default=0)

    @property
    def difficulty(self) -> str:
        """The level of the difficulty score: simple up to 2, moderate up to 4, complex above."""
        simple, moderate, complex_ = DIFFICULTIES
        score = self.difficulty_score
        return simple if score <= 2 else moderate if score <= 4 else complex_

    @property
    def axes(self) -> tuple[str, ...]:
        return tuple(sorted({AXIS_OF_ATTRIBUTE[a] for a in self.attributes} - {"instruction"}))

    def progress_layout(self) -> tuple[list[Condition], list[Stage], list[tuple[str, ...]]]:
        """Conditions to evaluate each step (their per-object columns, concatenated in order), the stages that read
        those columns, and each stage's target objects."""
        conditions: list[Condition] = []
        stages, targets = [], []
        column = 0
        for stage in self.subtasks:
            offsets = []
            for step in stage.steps:
                offsets.append(column)
                conditions.append(step)
                column += len(stage.objects)
            groups = tuple(
                Group(tuple(offset + i for offset in offsets), stage.weights) for i in range(len(stage.objects))
            )
            stages.append(Stage(groups, stage.logical, stage.k))
            targets.append(stage.objects)
        return conditions, stages, targets


def default_subtasks(condition: Condition) -> tuple[SubtaskStage, ...]:
    """One stage from a success condition: per object, grasped (weight 0), then the condition (weight 1)."""
    if PREDICATES[condition.predicate].group:
        logical, k = "all", 1
    else:
        logical, k = condition.logical, condition.k
    grasp = Condition("grasped", condition.objects, {})
    return (SubtaskStage(condition.objects, (grasp, condition), (0.0, 1.0), logical, k),)


# Allowed range of each predicate parameter that is a number: (low, high, above low only, unit). A key
# "<predicate>.<parameter>" overrides the parameter's general range for that predicate.
PARAM_LIMITS: dict[str, tuple[float, float, bool, str]] = {
    "distance": (0.0, 1.0, True, "m"),
    "tolerance": (0.0, 0.5, False, "m"),
    "margin": (0.0, 0.2, False, "m"),
    "cone_deg": (0.0, 90.0, True, "degrees"),
    "max_dz": (0.0, 10.0, True, "m"),
    "max_speed": (0.0, 10.0, True, "m/s"),
    "upright.tolerance": (0.0, math.pi, True, "rad"),
    "max_tilt": (0.0, math.pi, True, "rad"),
    "container_max_tilt": (0.0, math.pi, True, "rad"),
    "on_center.tolerance": (0.0, 0.5, True, "m"),
}
EVENT_LIMITS: dict[str, tuple[float, float, bool, str]] = {
    "wrong_grasp_closed": (0.0, 1.0, True, "(fraction closed)"),
    "fully_closed": (0.0, 1.0, True, "(fraction closed)"),
    "bump_distance": (0.0, 1.0, True, "m"),
    "move_distance": (0.0, 5.0, True, "m"),
    "scene_half_size": (0.0, 10.0, True, "m"),
    "tip_angle": (0.0, math.pi, True, "rad"),
}
MIN_OBJECTS = {"stacked": 2}  # a stack of one object would hold from the start
CONTAINER_REFERENCES = ("container",)  # reference fields that must name a scene object, not the table
MAX_EPISODE_SECONDS = 3600.0
MAX_STEP_WEIGHT = 1000.0


def _read_condition(fields: Fields, scene: SceneSpec, extra: tuple[str, ...] = (), objects=None) -> Condition:
    """A condition; `objects` given (subtask steps) means the field must be absent and these are used."""
    name = fields.get("predicate", str)
    if name not in PREDICATES:
        raise fields.error("predicate", f"'{name}' is not a known predicate", did_you_mean(name, PREDICATES))
    info = PREDICATES[name]
    allowed = ["predicate", "logical", "k", *FLAGS, *info.references, *info.params, *extra]
    if objects is None:
        allowed.append("objects")
    fields.only(allowed)
    known = [*scene.object_names(), TABLE]
    where = f"object of scene '{scene.name}' (or 'table')"
    params: dict[str, Any] = {}
    for key, default in info.params.items():
        if isinstance(default, dict):  # a mapping of container -> objects
            params[key] = _read_groups(fields, key, scene)
        elif isinstance(default, str):
            params[key] = fields.choice(key, STACK_ORDERS if key == "order" else [default], default)
        else:
            low, high, above, unit = PARAM_LIMITS.get(f"{name}.{key}") or PARAM_LIMITS[key]
            params[key] = fields.number(key, low, high, default, above=above, unit=unit)
    if objects is None:
        if "groups" in params and not fields.has("objects"):
            objects = [member for members in params["groups"].values() for member in members]
        else:
            objects = _read_objects(fields, "objects", scene)
        if "groups" in params:
            homes = {member for members in params["groups"].values() for member in members}
            for index, obj in enumerate(objects):
                if obj not in homes:
                    raise fields.error(
                        f"objects[{index}]",
                        f"'{obj}' is in none of the groups",
                        "Add it to a group of `groups`, or leave `objects` out",
                    )
    elif "groups" in params:  # a subtask step: the stage's objects
        homes = {member for members in params["groups"].values() for member in members}
        for obj in objects:
            if obj not in homes:
                raise fields.error(
                    "groups", f"'{obj}', an object of this stage, is in none of the groups", "Add it to a group"
                )
    if len(objects) < MIN_OBJECTS.get(name, 1):
        raise fields.error(
            "objects", f"has {len(objects)} object(s); '{name}' needs at least {MIN_OBJECTS[name]}", "Name more objects"
        )
    references = {}
    for key, default in info.references.items():
        if fields.has(key) or default is None:
            references[key] = fields.name_in(key, known, where)
            if references[key] in objects:
                raise fields.error(
                    key,
                    f"'{references[key]}' is also an object of this condition",
                    "An object cannot be its own reference; name another object",
                )
            if key in CONTAINER_REFERENCES and references[key] == TABLE:
                raise fields.error(key, "the table is not a container", "Name a container object of the scene")
        else:
            references[key] = default
    logical, k = _read_logical(fields, len(objects))
    contact = fields.get("require_contact_with", bool, False)
    if contact and info.contact_reference is None:
        raise fields.error(
            "require_contact_with",
            f"'{name}' has no reference object to touch",
            "Leave the flag out, or use a predicate with a reference",
        )
    return Condition(
        predicate=name,
        objects=tuple(str(o) for o in objects),
        references=references,
        logical=logical,
        k=k,
        require_contact_with=contact,
        require_gripper_detached=fields.get("require_gripper_detached", bool, False),
        params=params,
        require_picked_up=fields.get("require_picked_up", bool, False),
    )


def _read_objects(fields: Fields, key: str, scene: SceneSpec) -> list[str]:
    """A non-empty list of distinct objects of the scene (the table cannot be one: it does not move)."""
    values = fields.get(key, list)
    for index, value in enumerate(values):
        if value == TABLE:
            raise fields.error(
                f"{key}[{index}]",
                "the table cannot be moved, so it cannot be an object here",
                "Name objects of the scene; the table may be a reference (container, surface ...)",
            )
    objects = fields.names_in(key, scene.object_names(), f"object of scene '{scene.name}'")
    if not objects:
        raise fields.error(key, "is empty", "Name at least one object of the scene")
    return objects


def _read_logical(fields: Fields, count: int) -> tuple[str, int]:
    """`logical` (all / any / choose) and `k`, checked against the number of objects."""
    logical = fields.choice("logical", LOGICALS, "all")
    k = fields.get("k", int, 1)
    if fields.has("k") and logical != "choose":
        raise fields.error(
            "k", f"applies only with logical: choose (this is '{logical}')", "Leave k out, or set logical: choose"
        )
    if logical == "choose" and not fields.has("k"):
        raise fields.error(
            "k", "is missing: logical choose needs the number of objects to choose", f"Add k (1 to {count})"
        )
    if logical == "choose" and not 1 <= k <= count:
        raise fields.error("k", f"must be between 1 and the number of objects ({count}), got {k}")
    return logical, k


def _read_groups(fields: Fields, key: str, scene: SceneSpec) -> dict[str, list[str]]:
    """A mapping container -> objects; every object in one group only, never in its own container."""
    groups = fields.sub(key)
    if not groups.data:
        raise fields.error(key, "is empty", "Map at least one container to the objects that belong in it")
    result: dict[str, list[str]] = {}
    home: dict[str, str] = {}
    for container in groups.data:
        check_name(
            str(container),
            scene.object_names(),
            f"container of scene '{scene.name}'",
            lambda problem, fix, container=container: groups.error(str(container), problem, fix),
        )
        members = _read_objects(groups, container, scene)
        for index, member in enumerate(members):
            if member == container:
                raise groups.error(f"{container}[{index}]", f"'{member}' cannot go into itself", "Name other objects")
            if member in home:
                raise groups.error(
                    f"{container}[{index}]",
                    f"'{member}' is also in the group of '{home[member]}'",
                    "Put each object in one group",
                )
            home[member] = container
        result[str(container)] = members
    return result


def _read_stage(fields: Fields, scene: SceneSpec) -> SubtaskStage:
    fields.only(["objects", "logical", "k", "steps"])
    objects = _read_objects(fields, "objects", scene)
    logical, k = _read_logical(fields, len(objects))
    steps, weights = [], []
    for index, entry in enumerate(fields.get("steps", list)):
        step_fields = Fields(entry, fields.file, fields.where(f"steps[{index}]"))
        steps.append(_read_condition(step_fields, scene, extra=("weight",), objects=list(objects)))
        weights.append(step_fields.number("weight", 0.0, MAX_STEP_WEIGHT, 1.0))
    if not steps:
        raise fields.error("steps", "is empty", "Give at least one step")
    if sum(weights) <= 0:
        raise fields.error("steps", "every step has weight 0", "Give at least one step a positive weight")
    return SubtaskStage(tuple(objects), tuple(steps), tuple(weights), logical, k)


def _read_events(fields: Fields) -> dict[str, float]:
    """Event thresholds, each in its range; an object is bumped before it is moved."""
    thresholds = fields.sub("events", {})
    thresholds.only(EVENT_THRESHOLDS)
    values = {}
    for key, default in EVENT_THRESHOLDS.items():
        low, high, above, unit = EVENT_LIMITS[key]
        values[key] = thresholds.number(key, low, high, default, above=above, unit=unit)
    if values["bump_distance"] >= values["move_distance"]:
        key = "move_distance" if thresholds.has("move_distance") else "bump_distance"
        raise thresholds.error(
            key,
            f"bump_distance ({values['bump_distance']:g} m) must be less than move_distance "
            f"({values['move_distance']:g} m)",
            "Make bumping the smaller displacement",
        )
    return values


def _read_episode_seconds(fields: Fields) -> float:
    """The episode length: at least one control step, at most an hour."""
    seconds = fields.get("episode_seconds", float)
    if seconds * CONTROL_HZ < 1:
        raise fields.error(
            "episode_seconds",
            f"{seconds:g} s is shorter than one control step (1/{CONTROL_HZ} s)",
            "Give the episode length in seconds; tasks take tens of seconds",
        )
    if seconds > MAX_EPISODE_SECONDS:
        raise fields.error(
            "episode_seconds", f"{seconds:g} s is more than an hour", f"Give at most {MAX_EPISODE_SECONDS:g} seconds"
        )
    return seconds


def read_task(file: Path) -> TaskSpec:
    """Read and check a task spec file."""
    fields = Fields(load_yaml(file), file)
    fields.only(list(TASK_KEYS))
    name = fields.get("name", str)
    if name != file.stem:
        raise fields.error("name", f"'{name}' differs from the file name '{file.stem}'", "Make them the same")
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
        raise fields.error(
            "name",
            f"'{name}' is not usable in an environment id (RoboLab-{name}-v1)",
            "Use letters, digits and underscores, starting with a letter, e.g. BananaInBowl",
        )
    scene_field = fields.get("scene", str)
    if scene_field.endswith(".yaml"):  # a scene file next to the task file (for authoring and tests)
        scene_path = (file.parent / scene_field).resolve()
        if not scene_path.exists():
            raise fields.error("scene", f"file '{scene_path}' does not exist")
        scene = read_scene(scene_path)
    else:
        scene = load_scene(fields.name_in("scene", scene_names(near=file.parent), "scene"), near=file.parent)
    attributes = fields.names_in("attributes", AXIS_OF_ATTRIBUTE, "attribute", [])
    instructions = fields.sub("instructions")
    instructions.only(INSTRUCTION_VARIANTS)
    texts = {variant: instructions.get(variant, str) for variant in INSTRUCTION_VARIANTS}
    success = fields.get("success", list)
    if not success:
        raise fields.error("success", "is empty", "Give at least one success condition")
    conditions = tuple(_read_condition(Fields(entry, file, f"success[{i}]"), scene) for i, entry in enumerate(success))
    seconds = _read_episode_seconds(fields)
    stages = fields.get("subtasks", list, None)
    if stages == []:
        raise fields.error("subtasks", "is empty", "Give at least one stage, or leave subtasks out for the default")
    subtasks = (
        tuple(_read_stage(Fields(entry, file, f"subtasks[{i}]"), scene) for i, entry in enumerate(stages))
        if stages
        else default_subtasks(conditions[0])
    )
    contact = _read_objects(fields, "contact_objects", scene) if fields.has("contact_objects") else scene.object_names()
    event_thresholds = _read_events(fields)
    return TaskSpec(
        name, scene, file, seconds, tuple(attributes), texts, conditions, subtasks, tuple(contact), event_thresholds
    )


def task_names() -> list[str]:
    """Every known task: the shipped ones and those in user content folders (ROBOLAB_CONTENT, --content)."""
    return sorted(content_files("tasks"))


def is_task_file(task: str | Path) -> bool:
    """Whether `task` names a file (a path, or a name ending in .yaml / .yml) rather than a known task."""
    text = str(task)
    return isinstance(task, Path) or text.endswith((".yaml", ".yml")) or "/" in text or os.sep in text


def task_file(task: str | Path) -> Path:
    """The file of a task given by name (`BananaInBowl`), environment id (`RoboLab-BananaInBowl-v1`) or path."""
    if is_task_file(task):
        path = Path(task).expanduser()
        if not path.is_file():
            raise RoboLabError(f"task file '{task}' does not exist" + (" (it is a folder)" if path.is_dir() else ""))
        return path.resolve()
    name = str(task)
    if name.startswith("RoboLab-") and name.endswith("-v1"):
        name = name[len("RoboLab-") : -len("-v1")]
    files = content_files("tasks")
    if name not in files:
        raise UnknownNameError("task", name, files)
    return files[name]


def load_task(task: str | Path) -> TaskSpec:
    """A task by name (`BananaInBowl`), environment id (`RoboLab-BananaInBowl-v1`) or task file path (its scene is
    found next to it, or by name). Read afresh on every call: an edited file counts at once."""
    return read_task(task_file(task))


def load_all_tasks() -> list[TaskSpec]:
    """Every known task (see task_names), read and checked."""
    return [read_task(path) for _, path in sorted(content_files("tasks").items())]
