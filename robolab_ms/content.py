"""Where the shipped content lives, and strict reading of its YAML files.

Content (catalog, scene files, task specs) is data. Each file is read into plain dicts here and checked by the
schema of its kind (robolab_ms.catalog, robolab_ms.scene, robolab_ms.tasks.spec) through `Fields`, which turns
every mistake into a SpecError naming the file and the field.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

import yaml

from robolab_ms.errors import SpecError, did_you_mean

T = TypeVar("T")
REQUIRED: Any = object()

CONTENT_PACKAGES = {
    "assets": "robolab_ms.assets",
    "scenes": "robolab_ms.scene_builders",
    "tasks": "robolab_ms.task_specs",
}


def content_dir(kind: str) -> Path:
    """The folder holding one kind of shipped content: 'assets', 'scenes' or 'tasks'."""
    return Path(str(resources.files(CONTENT_PACKAGES[kind])))


def load_yaml(path: Path) -> dict[str, Any]:
    """Read a YAML mapping; syntax errors name the file and line."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise SpecError(path, "<file>", f"cannot be read ({error.strerror})") from None
    try:
        data = yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark else "<file>"
        raise SpecError(path, where, f"is not valid YAML ({getattr(error, 'problem', error)})") from None
    if not isinstance(data, dict):
        raise SpecError(path, "<top level>", "must be a mapping of field names to values")
    return data


class Fields:
    """Typed, checked access to one mapping of a content file; errors carry the file and the dotted field path."""

    def __init__(self, data: Any, file: str | Path, path: str = "") -> None:
        if not isinstance(data, dict):
            raise SpecError(file, path or "<top level>", f"must be a mapping, got {type(data).__name__}")
        self.data, self.file, self.path = data, file, path

    def where(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, problem: str, fix: str = "") -> SpecError:
        return SpecError(self.file, self.where(name), problem, fix)

    def get(self, name: str, kind: type[T] | tuple[type, ...], default: Any = REQUIRED) -> T:
        """The value of `name`, checked against `kind`; `default` when absent (required when not given)."""
        if name not in self.data or self.data[name] is None:
            if default is REQUIRED:
                raise self.error(name, "is missing", "Add it; it is required")
            return default
        value = self.data[name]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or (isinstance(value, bool) and kind in (int, float)):
            expected = kind.__name__ if isinstance(kind, type) else " or ".join(k.__name__ for k in kind)
            raise self.error(name, f"must be a {expected}, got {value!r}")
        return value

    def number_list(self, name: str, length: int, default: Any = REQUIRED) -> list[float]:
        value = self.get(name, list, default)
        if value is default and default is not REQUIRED:
            return value
        if len(value) != length or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            raise self.error(name, f"must be a list of {length} numbers, got {value!r}")
        return [float(v) for v in value]

    def sub(self, name: str, default: Any = REQUIRED) -> Fields:
        value = self.get(name, dict, default)
        return Fields(value, self.file, self.where(name))

    def choice(self, name: str, choices: Iterable[str], default: Any = REQUIRED) -> str:
        value = self.get(name, str, default)
        choices = list(choices)
        if value not in choices:
            raise self.error(name, f"'{value}' is not one of {', '.join(choices)}", did_you_mean(value, choices))
        return value

    def name_in(self, name: str, known: Iterable[str], what: str) -> str:
        """A string that must name one of `known` (an object, a scene ...)."""
        value = self.get(name, str)
        return check_name(value, known, what, lambda problem, fix: self.error(name, problem, fix))

    def names_in(self, name: str, known: Iterable[str], what: str, default: Any = REQUIRED) -> list[str]:
        """A list of strings that must each name one of `known`; errors point at the entry (`name[i]`)."""
        values = self.get(name, list, default)
        known = list(known)
        for index, value in enumerate(values):
            check_name(str(value), known, what, lambda problem, fix: self.error(f"{name}[{index}]", problem, fix))
        return [str(value) for value in values]

    def only(self, allowed: Iterable[str]) -> None:
        """Reject fields this schema does not know (typos would otherwise be ignored silently)."""
        allowed = list(allowed)
        for key in self.data:
            if key not in allowed:
                raise self.error(str(key), "is not a known field", did_you_mean(str(key), allowed))


def check_name(value: str, known: Iterable[str], what: str, make_error: Callable[[str, str], Exception]) -> str:
    known = list(known)
    if value not in known:
        raise make_error(f"names unknown {what} '{value}'", did_you_mean(value, known))
    return value
