"""A success condition's parsed form: one predicate over objects, as task specs write it and predicates read it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


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
    require_picked_up: bool = False  # the object was picked up at some step (latched): not knocked into place

    @property
    def required_count(self) -> int:
        """How many of its objects must satisfy it: all of them, one (`any`) or k (`choose`)."""
        return {"all": len(self.objects), "any": 1, "choose": self.k}[self.logical]
