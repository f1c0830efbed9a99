"""Task specs: one YAML file per task in task_specs/, read and checked here.

A task is a scene, three instruction variants, one or more success conditions (any one suffices), its attributes,
and optionally subtasks (stages of weighted steps), the objects whose contacts matter for events, and event
thresholds. Without `subtasks`, they are derived from the first success condition: for each of its objects,
"grasped" (weight 0) then the condition itself (weight 1), combined by the condition's logical (all / any / choose K).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from robolab_ms.content import Fields, check_name, content_dir, load_yaml
from robolab_ms.errors import UnknownNameError, did_you_mean
from robolab_ms.scene import SceneSpec, load_scene, read_scene, scene_names
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


@dataclass(frozen=True, eq=False)
class Condition:
    """One predicate applied to objects, with its reference objects, multi-object logic, flags and parameters."""

    predicate: str
    objects: tuple[str, ...]
    references: dict[str, str]
    logical: str = "all"
    k: int = 1
    require_contact_with: bool = False
    require_gripper_detached: bool = False
    params: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class SubtaskStage:
    """A stage: one group per object, each group running the same ordered, weighted steps on its own object."""

    objects: tuple[str, ...]
    steps: tuple[Condition, ...]  # each over all of `objects`; group i uses column i
    weights: tuple[float, ...]
    logical: str = "all"
    k: int = 1


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
        """Subtasks summed over stages: a stage counts its groups (`all`), 1 (`any`) or K (`choose`)."""
        return sum({"all": len(s.objects), "any": 1, "choose": s.k}[s.logical] for s in self.subtasks)

    @property
    def difficulty_score(self) -> int:
        """Number of subtasks plus the largest skill weight among the attributes (RoboLab's rating)."""
        return self.num_subtasks + max((SKILL_WEIGHT[a] for a in self.attributes), default=0)

    @property
    def difficulty(self) -> str:
        score = self.difficulty_score
        return "simple" if score <= 2 else "moderate" if score <= 4 else "complex"

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
            groups = tuple(Group(tuple(offset + i for offset in offsets), stage.weights)
                           for i in range(len(stage.objects)))  # fmt: skip
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
    params = {}
    for key, default in info.params.items():
        if isinstance(default, dict):  # a mapping of container -> objects
            params[key] = _read_groups(fields, key, known, where)
        else:
            params[key] = fields.get(key, type(default), default)
    if objects is None:
        if "groups" in params and "objects" not in fields.data:
            objects = [member for members in params["groups"].values() for member in members]
        else:
            objects = fields.names_in("objects", known, where)
    if not objects:
        raise fields.error("objects", "is empty", "Name at least one object of the scene")
    references = {}
    for key, default in info.references.items():
        if key in fields.data or default is None:
            references[key] = fields.name_in(key, known, where)
        else:
            references[key] = default
    logical, k = _read_logical(fields, len(objects))
    if "order" in params and params["order"] not in STACK_ORDERS:
        raise fields.error("order", f"'{params['order']}' is not valid", f"Use one of {', '.join(STACK_ORDERS)}")
    return Condition(
        predicate=name,
        objects=tuple(str(o) for o in objects),
        references=references,
        logical=logical,
        k=k,
        require_contact_with=fields.get("require_contact_with", bool, False),
        require_gripper_detached=fields.get("require_gripper_detached", bool, False),
        params=params,
    )


def _read_logical(fields: Fields, count: int) -> tuple[str, int]:
    """`logical` (all / any / choose) and `k`, checked against the number of objects."""
    logical = fields.choice("logical", LOGICALS, "all")
    k = fields.get("k", int, 1)
    if logical == "choose" and not 1 <= k <= count:
        raise fields.error("k", f"must be between 1 and the number of objects ({count}), got {k}")
    return logical, k


def _read_groups(fields: Fields, key: str, known: list[str], where: str) -> dict[str, list[str]]:
    groups = fields.sub(key)
    result = {}
    for container in groups.data:
        check_name(str(container), known, where, lambda problem, fix: groups.error(str(container), problem, fix))
        members = groups.names_in(container, known, where)
        if not members:
            raise groups.error(str(container), "is empty", "List at least one object")
        result[str(container)] = members
    return result


def _read_stage(fields: Fields, scene: SceneSpec) -> SubtaskStage:
    fields.only(["objects", "logical", "k", "steps"])
    objects = fields.names_in("objects", scene.object_names(), f"object of scene '{scene.name}'")
    logical, k = _read_logical(fields, len(objects))
    steps, weights = [], []
    for index, entry in enumerate(fields.get("steps", list)):
        step_fields = Fields(entry, fields.file, fields.where(f"steps[{index}]"))
        steps.append(_read_condition(step_fields, scene, extra=("weight",), objects=list(objects)))
        weight = step_fields.get("weight", float, 1.0)
        if weight < 0:
            raise step_fields.error("weight", f"must not be negative, got {weight}")
        weights.append(weight)
    if not steps:
        raise fields.error("steps", "is empty", "Give at least one step")
    return SubtaskStage(tuple(objects), tuple(steps), tuple(weights), logical, k)


def read_task(file: Path) -> TaskSpec:
    """Read and check a task spec file."""
    fields = Fields(load_yaml(file), file)
    fields.only(["name", "scene", "episode_seconds", "attributes", "instructions", "success", "subtasks",
                 "contact_objects", "events"])
    name = fields.get("name", str)
    if name != file.stem:
        raise fields.error("name", f"'{name}' differs from the file name '{file.stem}'", "Make them the same")
    scene_field = fields.get("scene", str)
    if scene_field.endswith(".yaml"):  # a scene file next to the task file (for authoring and tests)
        scene_path = (file.parent / scene_field).resolve()
        if not scene_path.exists():
            raise fields.error("scene", f"file '{scene_path}' does not exist")
        scene = read_scene(scene_path)
    else:
        scene = load_scene(fields.name_in("scene", scene_names(), "scene"))
    attributes = fields.names_in("attributes", AXIS_OF_ATTRIBUTE, "attribute", [])
    instructions = fields.sub("instructions")
    instructions.only(INSTRUCTION_VARIANTS)
    texts = {variant: instructions.get(variant, str) for variant in INSTRUCTION_VARIANTS}
    success = fields.get("success", list)
    if not success:
        raise fields.error("success", "is empty", "Give at least one success condition")
    conditions = tuple(_read_condition(Fields(entry, file, f"success[{i}]"), scene) for i, entry in enumerate(success))
    seconds = fields.get("episode_seconds", float)
    if seconds <= 0:
        raise fields.error("episode_seconds", f"must be positive, got {seconds}")
    stages = fields.get("subtasks", list, None)
    subtasks = (tuple(_read_stage(Fields(entry, file, f"subtasks[{i}]"), scene) for i, entry in enumerate(stages))
                if stages else default_subtasks(conditions[0]))  # fmt: skip
    contact = fields.names_in("contact_objects", scene.object_names(), f"object of scene '{scene.name}'",
                              scene.object_names())  # fmt: skip
    thresholds = fields.sub("events", {})
    thresholds.only(EVENT_THRESHOLDS)
    event_thresholds = {key: thresholds.get(key, float, default) for key, default in EVENT_THRESHOLDS.items()}
    return TaskSpec(name, scene, file, seconds, tuple(attributes), texts, conditions, subtasks,
                    tuple(contact), event_thresholds)


def task_names() -> list[str]:
    return sorted(path.stem for path in content_dir("tasks").glob("*.yaml"))


@lru_cache(maxsize=None)
def load_task(name: str) -> TaskSpec:
    """A shipped task by name (`BananaInBowl`) or environment id (`RoboLab-BananaInBowl-v1`), or a task file."""
    if name.endswith(".yaml"):
        return read_task(Path(name))
    if name.startswith("RoboLab-") and name.endswith("-v1"):
        name = name[len("RoboLab-"):-len("-v1")]
    path = content_dir("tasks") / f"{name}.yaml"
    if not path.exists():
        raise UnknownNameError("task", name, task_names())
    return read_task(path)


def load_all_tasks() -> list[TaskSpec]:
    return [load_task(name) for name in task_names()]
