"""Scenes: scene files read and checked in `.spec`, outlines seen from above in `.outlines`, one object resting on
another in `.support`, the per-episode jitter in `.jitter`, the ManiSkill SceneBuilder in `.builder` (the room's
fixed light and table rules in `.room`), backgrounds in `.backgrounds`, USD in `.usd_export` / `.usd_import`.
"""

from robolab_ms.scene.spec import (
    DEFAULT_TABLE_COLOR,
    DEFAULT_TABLE_SIZE,
    DIRECTIONS,
    IDENTITY_QUAT,
    OVERLAP_TOLERANCE,
    RESERVED_NAMES,
    SAFE_PLACEMENT,
    SETTLE_CLEARANCE,
    TABLE_CENTER_XY,
    TABLE_HEIGHT,
    ObjectPlacement,
    SceneSpec,
    footprint,
    load_scene,
    load_scene_or_file,
    read_scene,
    resting_height,
    scene_files,
    scene_names,
)

__all__ = [
    "DEFAULT_TABLE_COLOR",
    "DEFAULT_TABLE_SIZE",
    "DIRECTIONS",
    "IDENTITY_QUAT",
    "OVERLAP_TOLERANCE",
    "RESERVED_NAMES",
    "SAFE_PLACEMENT",
    "SETTLE_CLEARANCE",
    "TABLE_CENTER_XY",
    "TABLE_HEIGHT",
    "ObjectPlacement",
    "SceneSpec",
    "footprint",
    "load_scene",
    "load_scene_or_file",
    "read_scene",
    "resting_height",
    "scene_files",
    "scene_names",
]
