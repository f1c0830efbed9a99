"""Task specs: one YAML file per task in task_specs/, read and checked here.

A task is a scene, three instruction variants, one or more success conditions (any one suffices) and its
attributes. Subtasks are derived from the first success condition: for each of its objects, "grasped" (weight 0)
then the condition itself (weight 1), combined by the condition's logical (all / any / choose K).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from robolab_ms.content import Fields, check_name, content_dir, load_yaml
from robolab_ms.errors import UnknownNameError, did_you_mean
from robolab_ms.scene import SceneSpec, load_scene, scene_names
from robolab_ms.tasks.predicates import FLAGS, PREDICATES
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


@dataclass(frozen=True)
class Condition:
    """One predicate applied to objects, with the multi-object logic and flags."""

    predicate: str
    objects: tuple[str, ...]
    reference: str | None
    logical: str
    k: int
    require_contact_with: bool
    require_gripper_detached: bool
    params: dict[str, Any]

    @property
    def subtask_count(self) -> int:
        return {"all": len(self.objects), "any": 1, "choose": self.k}[self.logical]


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

    @property
    def env_id(self) -> str:
        return f"RoboLab-{self.name}-v1"

    @property
    def max_episode_steps(self) -> int:
        return round(self.episode_seconds * CONTROL_HZ)

    @property
    def num_subtasks(self) -> int:
        return self.success[0].subtask_count

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

    def target_objects(self) -> list[str]:
        """Objects named by any success condition, in order of first mention."""
        names: list[str] = []
        for condition in self.success:
            names += [name for name in condition.objects if name not in names]
        return names

    def progress_layout(self) -> tuple[list[Condition], list[Stage]]:
        """The per-object conditions to evaluate each step, and the stages that consume them (by index)."""
        first = self.success[0]
        conditions: list[Condition] = []
        groups = []
        for name in first.objects:
            grasp = Condition("grasped", (name,), None, "all", 1, False, False, {})
            placed = Condition(first.predicate, (name,), first.reference, "all", 1,
                               first.require_contact_with, first.require_gripper_detached, first.params)
            groups.append(Group((len(conditions), len(conditions) + 1), (0.0, 1.0)))
            conditions += [grasp, placed]
        return conditions, [Stage(tuple(groups), first.logical, first.k)]


def _read_condition(fields: Fields, scene: SceneSpec) -> Condition:
    name = fields.get("predicate", str)
    if name not in PREDICATES:
        raise fields.error("predicate", f"'{name}' is not a known predicate", did_you_mean(name, PREDICATES))
    info = PREDICATES[name]
    allowed = ["predicate", "objects", "logical", "k", *FLAGS, *info.params]
    if info.reference:
        allowed.append(info.reference)
    fields.only(allowed)
    objects = fields.get("objects", list)
    known = scene.object_names()
    for index, obj in enumerate(objects):
        check_name(str(obj), known, f"object of scene '{scene.name}'",
                   lambda problem, fix: fields.error(f"objects[{index}]", problem, fix))
    if not objects:
        raise fields.error("objects", "is empty", "Name at least one object of the scene")
    reference = fields.name_in(info.reference, known, f"object of scene '{scene.name}'") if info.reference else None
    logical = fields.choice("logical", LOGICALS, "all")
    k = fields.get("k", int, 1)
    if logical == "choose" and not 1 <= k <= len(objects):
        raise fields.error("k", f"must be between 1 and the number of objects ({len(objects)}), got {k}")
    params = {key: fields.get(key, type(default), default) for key, default in info.params.items()}
    return Condition(
        predicate=name,
        objects=tuple(str(o) for o in objects),
        reference=reference,
        logical=logical,
        k=k,
        require_contact_with=fields.get("require_contact_with", bool, False),
        require_gripper_detached=fields.get("require_gripper_detached", bool, False),
        params=params,
    )


def read_task(file: Path) -> TaskSpec:
    """Read and check a task spec file."""
    fields = Fields(load_yaml(file), file)
    fields.only(["name", "scene", "episode_seconds", "attributes", "instructions", "success"])
    name = fields.get("name", str)
    if name != file.stem:
        raise fields.error("name", f"'{name}' differs from the file name '{file.stem}'", "Make them the same")
    scene_name = fields.name_in("scene", scene_names(), "scene")
    scene = load_scene(scene_name)
    attributes = fields.get("attributes", list, [])
    for index, attribute in enumerate(attributes):
        check_name(str(attribute), AXIS_OF_ATTRIBUTE, "attribute",
                   lambda problem, fix: fields.error(f"attributes[{index}]", problem, fix))
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
    return TaskSpec(name, scene, file, seconds, tuple(str(a) for a in attributes), texts, conditions)


def task_names() -> list[str]:
    return sorted(path.stem for path in content_dir("tasks").glob("*.yaml"))


@lru_cache(maxsize=None)
def load_task(name: str) -> TaskSpec:
    """A shipped task by name (`BananaInBowl`) or environment id (`RoboLab-BananaInBowl-v1`)."""
    if name.startswith("RoboLab-") and name.endswith("-v1"):
        name = name[len("RoboLab-"):-len("-v1")]
    path = content_dir("tasks") / f"{name}.yaml"
    if not path.exists():
        raise UnknownNameError("task", name, task_names())
    return read_task(path)


def load_all_tasks() -> list[TaskSpec]:
    return [load_task(name) for name in task_names()]
