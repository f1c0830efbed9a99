"""The oracle's one error: it cannot solve an episode, and the message says why."""

from __future__ import annotations

from robolab_ms.errors import RoboLabError


class OracleFailure(RoboLabError):
    """The oracle cannot solve this episode; the message says why."""
