"""Errors a user can act on. The CLI prints them as one message, without a traceback."""

from __future__ import annotations

import difflib
import os
from collections.abc import Iterable
from pathlib import Path


class RoboLabError(Exception):
    """A problem with input or set-up that the user can fix; the message says how."""


class SpecError(RoboLabError):
    """A scene, task or catalog file is invalid: names the file, the field and what would be valid."""

    def __init__(self, file: str | Path, field: str, problem: str, fix: str = "") -> None:
        self.file = str(file)
        self.field = field
        self.problem = problem
        self.fix = fix
        message = f"{self.file}: field '{field}': {problem}"
        if fix:
            message += f". {fix}"
        super().__init__(message)


class ResultsError(RoboLabError):
    """A results file that cannot be read (a line of `episodes.jsonl`, a recording's .json or .h5): names the file,
    the line where there is one, the field and a fix."""

    def __init__(self, file: str | Path, line: int | None, field: str, problem: str, fix: str = "") -> None:
        self.file = str(file)
        self.line = line
        self.field = field
        self.problem = problem
        self.fix = fix
        message = self.file + (f" line {line}" if line is not None else "") + (f", field '{field}'" if field else "")
        message += f": {problem}"
        if fix:
            message += f". {fix}"
        super().__init__(message)


class UnknownNameError(RoboLabError):
    """A name (task, object, predicate, policy ...) that does not exist; suggests close matches."""

    def __init__(self, kind: str, name: str, known: Iterable[str]) -> None:
        known = sorted(known)
        self.kind, self.name, self.known = kind, name, known
        super().__init__(f"unknown {kind} '{name}'. {did_you_mean(name, known)}")


def make_folder(path: str | Path, option: str = "") -> Path:
    """Create an output folder (with its parents) and return it; a RoboLabError naming the option, the folder and
    why, when it cannot be made (a file in the way, no permission) or is not writable."""
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        blocking = next((p for p in [path, *path.parents] if p.exists() and not p.is_dir()), path)
        raise RoboLabError(f"{where}: cannot create this folder: {blocking} is a file; choose another folder") from None
    except OSError as error:
        raise RoboLabError(
            f"{where}: cannot create this folder ({error.strerror or error}); choose a folder you can write to"
        ) from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise RoboLabError(f"{where}: this folder is not writable; choose a folder you can write to")
    return path


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """A short hint naming the closest valid names, or listing a few valid ones."""
    known = sorted(known)
    close = difflib.get_close_matches(name, known, n=3, cutoff=0.5)
    if not close:
        lowered = {k.lower(): k for k in known}
        close = [lowered[k] for k in difflib.get_close_matches(name.lower(), list(lowered), n=3, cutoff=0.5)]
    if close:
        return "Did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
    shown = ", ".join(known[:8]) + (", ..." if len(known) > 8 else "")
    return f"Valid names: {shown}" if known else "There are none defined."
