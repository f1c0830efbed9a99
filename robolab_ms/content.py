"""Where the shipped content lives, and strict reading of its YAML files.

Content (catalog, scene files, task specs) is data. Each file is read into plain dicts here and checked by the
schema of its kind (robolab_ms.catalog, robolab_ms.scene, robolab_ms.tasks.spec) through `Fields`, which turns
every mistake into a SpecError naming the file and the field.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

import yaml

from robolab_ms.errors import RoboLabError, SpecError, did_you_mean

T = TypeVar("T")
REQUIRED: Any = object()

CONTENT_PACKAGES = {
    "assets": "robolab_ms.assets",
    "scenes": "robolab_ms.scene_builders",
    "tasks": "robolab_ms.task_specs",
}
CONTENT_FOLDERS = {"assets": "assets", "scenes": "scene_builders", "tasks": "task_specs"}  # as in the checkout
USER_KINDS = ("tasks", "scenes")  # what a user content folder may add, besides catalog objects (USER_CATALOG)
USER_CATALOG = "assets/catalog.yaml"  # a user content folder's own catalog objects (`robolab catalog add` writes it)
CONTENT_ENV = "ROBOLAB_CONTENT"  # user content folders, separated by os.pathsep
CHECKOUT_FILE = "checkout.txt"  # written into the installed package by `make` (see setup.py): the checkout's path
CHECKOUT_ENV = "ROBOLAB_MS_LINK_CHECKOUT"  # set to 1 while building, records the checkout in CHECKOUT_FILE
CACHE_ENV = "ROBOLAB_MS_CACHE"  # the cache folder, when set

_added_roots: list[Path] = []  # folders added with add_content_root (the CLI's --content)


@lru_cache(maxsize=None)
def checkout_root() -> Path | None:
    """The checkout this installed copy was built from, when `make` recorded it (CHECKOUT_FILE) and it still holds
    the content folders; None otherwise (a plain `pip install`, or running from the checkout itself)."""
    try:
        text = resources.files("robolab_ms").joinpath(CHECKOUT_FILE).read_text(encoding="utf-8").strip()
    except (OSError, ValueError):
        return None
    root = Path(text)
    return root if text and all((root / folder).is_dir() for folder in CONTENT_FOLDERS.values()) else None


def content_dir(kind: str) -> Path:
    """The folder holding one kind of shipped content: 'assets', 'scenes' or 'tasks'. An installation made by `make`
    reads the checkout's folders, so edits there take effect without a re-install; otherwise the package's own."""
    root = checkout_root()
    if root is not None:
        return root / CONTENT_FOLDERS[kind]
    return Path(str(resources.files(CONTENT_PACKAGES[kind])))


def cache_dir() -> Path:
    """Where derived files are kept between runs (coacd's pieces, ...): $ROBOLAB_MS_CACHE, else
    $XDG_CACHE_HOME/robolab_ms, else ~/.cache/robolab_ms (as robolab_ms.agents.droid_model.cache_dir)."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "robolab_ms"


def check_content_root(folder: str | Path, origin: str) -> Path:
    """A user content folder, checked: it must exist and hold task_specs/, scene_builders/ or assets/catalog.yaml."""
    path = Path(folder).expanduser()
    if not path.is_dir():
        raise RoboLabError(
            f"{origin}: '{folder}' is not a folder. Name a folder that holds task_specs/ and/or scene_builders/"
        )
    if not any((path / CONTENT_FOLDERS[kind]).is_dir() for kind in USER_KINDS) and not (path / USER_CATALOG).is_file():
        raise RoboLabError(
            f"{origin}: '{folder}' holds neither task_specs/ nor scene_builders/ nor {USER_CATALOG}. "
            f"Put task files in {path / 'task_specs'}, scene files in {path / 'scene_builders'}, "
            "catalog objects with 'robolab catalog add'"
        )
    return path.resolve()


def add_content_root(folder: str | Path) -> Path:
    """Add a user content folder for this process (after those of ROBOLAB_CONTENT); returns it, resolved."""
    path = check_content_root(folder, "--content")
    if path not in _added_roots:
        _added_roots.append(path)
    return path


def user_content_roots() -> list[Path]:
    """User content folders, in search order: those in ROBOLAB_CONTENT, then those added with add_content_root."""
    entries = [entry.strip() for entry in os.environ.get(CONTENT_ENV, "").split(os.pathsep) if entry.strip()]
    roots: list[Path] = []
    for path in [*(check_content_root(entry, CONTENT_ENV) for entry in entries), *_added_roots]:
        if path not in roots:
            roots.append(path)
    return roots


def content_dirs(kind: str) -> list[Path]:
    """Every folder searched for tasks or scenes: the shipped one first, then each user content folder's."""
    folders = [content_dir(kind)]
    if kind in USER_KINDS:
        for root in user_content_roots():
            folder = root / CONTENT_FOLDERS[kind]
            if folder.is_dir() and folder.resolve() not in {known.resolve() for known in folders}:
                folders.append(folder)
    return folders


def content_files(kind: str) -> dict[str, Path]:
    """Every task or scene file by name (the file name without .yaml), from content_dirs(kind). A name found in
    two folders is an error naming both files."""
    found: dict[str, Path] = {}
    for folder in content_dirs(kind):
        for path in sorted(folder.glob("*.yaml")):
            if path.stem in found:
                what = "task" if kind == "tasks" else "scene"
                raise RoboLabError(
                    f"{what} '{path.stem}' is defined twice: {found[path.stem]} and {path}. Names must be unique "
                    f"across the shipped content and the folders of {CONTENT_ENV} / --content; rename one of the "
                    f"files (its file name is the {what} name, and the name field inside must match)"
                )
            found[path.stem] = path
    return found


def load_yaml(path: Path) -> dict[str, Any]:
    """Read a YAML mapping from a UTF-8 file; bad bytes, syntax errors and keys given twice name the file and the
    line or field."""
    try:
        raw = Path(path).read_bytes()
    except OSError as error:
        raise SpecError(path, "<file>", f"cannot be read ({error.strerror})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        line = raw.count(b"\n", 0, error.start) + 1
        raise SpecError(
            path,
            f"line {line}",
            f"is not UTF-8 text (byte 0x{raw[error.start]:02x} at offset {error.start})",
            "Save the file with the UTF-8 encoding",
        ) from None
    loader = YAML_LOADER(text)
    try:
        node = loader.get_single_node()
        if node is not None:
            _refuse_repeated_keys(node, path)
        data = loader.construct_document(node) if node is not None else None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark else "<file>"
        raise SpecError(path, where, f"is not valid YAML ({getattr(error, 'problem', None) or error})") from None
    finally:
        loader.dispose()
    if not isinstance(data, dict):
        raise SpecError(path, "<top level>", "must be a mapping of field names to values")
    return data


YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
MERGE_TAG = "tag:yaml.org,2002:merge"


def _refuse_repeated_keys(root: yaml.Node, file: Path) -> None:
    """A mapping that gives one key twice is an error (YAML loaders otherwise keep the last value silently)."""
    stack: list[tuple[yaml.Node, str]] = [(root, "")]
    visited: set[int] = set()
    while stack:
        node, where = stack.pop()
        if id(node) in visited:  # an alias of a node seen before
            continue
        visited.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            stack.extend((item, f"{where}[{index}]") for index, item in enumerate(node.value))
        elif isinstance(node, yaml.MappingNode):
            first_line: dict[tuple[str, str], int] = {}
            for key, value in node.value:
                if key.tag == MERGE_TAG:
                    continue
                text = key.value if isinstance(key, yaml.ScalarNode) else f"<line {key.start_mark.line + 1}>"
                field = f"{where}.{text}" if where else text
                line = key.start_mark.line + 1
                if isinstance(key, yaml.ScalarNode) and (key.tag, key.value) in first_line:
                    raise SpecError(
                        file,
                        field,
                        f"is given twice (lines {first_line[key.tag, key.value]} and {line})",
                        "Keep one of them",
                    )
                if isinstance(key, yaml.ScalarNode):
                    first_line[key.tag, key.value] = line
                stack.append((value, field))


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

    def has(self, name: str) -> bool:
        """Whether `name` is given (a field set to null counts as not given)."""
        return self.data.get(name) is not None

    def get(self, name: str, kind: type[T] | tuple[type, ...], default: Any = REQUIRED) -> T:
        """The value of `name`, checked against `kind`; `default` when absent (required when not given). Numbers must
        be finite and text must not be blank."""
        if not self.has(name):
            if default is REQUIRED:
                raise self.error(name, "is missing", "Add it; it is required")
            return default
        return check_kind(self.data[name], kind, lambda problem, fix: self.error(name, problem, fix))

    def number(
        self, name: str, low: float, high: float, default: Any = REQUIRED, *, above: bool = False, unit: str = ""
    ) -> float:
        """A finite number in [low, high] (in (low, high] when `above`); `default` when absent."""
        if not self.has(name):
            return self.get(name, float, default)
        value = self.get(name, float)
        check_range(value, low, high, above, unit, lambda problem, fix: self.error(name, problem, fix))
        return value

    def positive(self, name: str, high: float, default: Any = REQUIRED, unit: str = "") -> float:
        """A finite number above 0 and at most `high`."""
        return self.number(name, 0.0, high, default, above=True, unit=unit)

    def number_list(
        self,
        name: str,
        length: int,
        default: Any = REQUIRED,
        low: float = -math.inf,
        high: float = math.inf,
        above: bool = False,
        unit: str = "",
    ) -> list[float]:
        """A list of `length` finite numbers, each in [low, high] (in (low, high] when `above`)."""
        if not self.has(name):
            return self.get(name, list, default)
        value = self.get(name, list)
        if len(value) != length:
            raise self.error(name, f"must be a list of {length} numbers, got {value!r}")
        numbers = []
        for index, item in enumerate(value):

            def make_error(problem: str, fix: str, index: int = index) -> SpecError:
                return self.error(f"{name}[{index}]", problem, fix)

            number = check_kind(item, float, make_error)
            check_range(number, low, high, above, unit, make_error)
            numbers.append(number)
        return numbers

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
        """A list of distinct strings that must each name one of `known`; errors point at the entry (`name[i]`)."""
        if not self.has(name):
            return list(self.get(name, list, default))
        values = self.get(name, list)
        known = list(known)
        for index, value in enumerate(values):

            def make_error(problem: str, fix: str, index: int = index) -> SpecError:
                return self.error(f"{name}[{index}]", problem, fix)

            check_name(check_kind(value, str, make_error), known, what, make_error)
            if value in values[:index]:
                raise make_error(f"'{value}' is listed twice (also at [{values.index(value)}])", "List it once")
        return list(values)

    def only(self, allowed: Iterable[str]) -> None:
        """Reject fields this schema does not know (typos would otherwise be ignored silently)."""
        allowed = list(allowed)
        for key in self.data:
            if key not in allowed:
                raise self.error(str(key), "is not a known field", did_you_mean(str(key), allowed))


KIND_NAMES = {float: "number", int: "whole number", str: "text", bool: "true or false", list: "list", dict: "mapping"}


def check_kind(value: Any, kind: type[T] | tuple[type, ...], make_error: Callable[[str, str], Exception]) -> T:
    """`value` checked against `kind` (an int is a float, a bool is not a number); numbers finite, text not blank."""
    kinds = kind if isinstance(kind, tuple) else (kind,)
    if float in kinds and isinstance(value, int) and not isinstance(value, bool):
        if abs(value) > 1e300:
            raise make_error(f"is far too large ({len(str(abs(value)))} digits)", "Write a plain number such as 0.5")
        value = float(value)
    if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
        expected = " or ".join(KIND_NAMES.get(k, k.__name__) for k in kinds)
        expected = f"{'an' if expected[0] in 'aeiou' else 'a'} {expected}"
        fix = f"Write {expected} here"
        if float in kinds and isinstance(value, str) and _reads_as_number(value):
            fix = "YAML reads a number like 1e9 as text: write 1.0e+9 (a dot and a signed exponent) or the plain number"
        raise make_error(f"must be {expected}, got {value!r}", fix)
    if isinstance(value, float) and not math.isfinite(value):
        raise make_error(f"must be a finite number, got {value}", "Write a plain number such as 0.5")
    if isinstance(value, str) and not value.strip():
        raise make_error("is empty", "Write some text")
    return value


def _reads_as_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def check_range(
    value: float, low: float, high: float, above: bool, unit: str, make_error: Callable[[str, str], Exception]
) -> None:
    """`value` must be in [low, high], or in (low, high] when `above`."""
    unit = f" {unit}" if unit else ""
    if above:
        fix = f"Use a value above {low:g} and at most {high:g}{unit}"
    else:
        fix = f"Use a value from {low:g} to {high:g}{unit}"
    if above and value <= low:
        raise make_error(f"must be {'positive' if low == 0 else f'above {low:g}{unit}'}, got {value:g}", fix)
    if value < low or value > high:
        raise make_error(f"must be between {low:g} and {high:g}{unit}, got {value:g}", fix)


def check_name(value: str, known: Iterable[str], what: str, make_error: Callable[[str, str], Exception]) -> str:
    known = list(known)
    if value not in known:
        raise make_error(f"names unknown {what} '{value}'", did_you_mean(value, known))
    return value
