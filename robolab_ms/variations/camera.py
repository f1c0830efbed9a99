"""Camera pose: uniform offsets of each policy camera's mount at reset, RoboLab's ranges by default.

External cameras move in the world frame (x, y +-0.2 m, z +-0.1 m) and turn about their own axes (roll about the
viewing direction, pitch, yaw; +-0.2 rad); the wrist camera moves in the gripper mount's frame (x, y +-0.015 m) and
turns +-0.05 rad. Each camera draws its own offsets; `camera=external`, `camera=wrist` and `camera=both` are
RoboLab's three conditions.
"""

from __future__ import annotations

from typing import Any

from robolab_ms.variations.base import Axis, Context, FieldValue, Param, Range, Uniform

CAMERAS = ("external_left", "external_right", "wrist")
OFFSETS = ("dx", "dy", "dz", "droll", "dpitch", "dyaw")
EXTERNAL = {"xy": 0.2, "z": 0.1, "rot": 0.2}  # RoboLab's ranges: m, m, rad
WRIST = {"xy": 0.015, "z": 0.0, "rot": 0.05}


def _param(group: str, key: str, value: float) -> Param:
    unit = " rad" if key == "rot" else " m"
    what = {"xy": "x and y offset", "z": "z offset", "rot": "roll, pitch and yaw offset"}[key]
    return Param(
        f"{group}_{key}",
        "offset",
        Uniform(0.0, 0.0),
        Uniform(-value or 0.0, value),
        f"{group} cameras: {what}",
        -1.0,
        1.0,
        unit=unit,
    )


class CameraAxis(Axis):
    name = "camera"
    summary = "pose offsets of the external cameras and of the wrist camera"
    params = tuple(_param("external", key, value) for key, value in EXTERNAL.items()) + tuple(
        _param("wrist", key, value) for key, value in WRIST.items()
    )
    shorthand = None
    presets = {
        "external": {f"external_{key}": value for key, value in EXTERNAL.items()},
        "wrist": {f"wrist_{key}": value for key, value in WRIST.items() if value},
        "both": {
            **{f"external_{k}": v for k, v in EXTERNAL.items()},
            **{f"wrist_{k}": v for k, v in WRIST.items() if v},
        },
    }

    def sample(self, ranges: dict[str, Range], seed: int, context: Context) -> dict[str, FieldValue]:
        fields: dict[str, FieldValue] = {}
        for camera in CAMERAS:
            group = "wrist" if camera == "wrist" else "external"
            keys = ("xy", "xy", "z", "rot", "rot", "rot")
            values = [
                ranges[f"{group}_{key}"].draw(_stream(seed, camera, offset)) for key, offset in zip(keys, OFFSETS)
            ]
            if camera in context.cameras:  # every camera draws, so choosing cameras changes no other camera's pose
                fields.update({f"cam_{camera}_{offset}": round(value, 5) for offset, value in zip(OFFSETS, values)})
        return fields

    def camera_configs(self, configs: list, fields: dict[str, FieldValue]) -> list:
        for config in configs:
            if f"cam_{config.uid}_dx" in fields:
                config.pose = offset_pose(config.pose, [float(fields[f"cam_{config.uid}_{o}"]) for o in OFFSETS])
        return configs


def offset_pose(pose: Any, offsets: list[float]) -> Any:
    """`pose` (a ManiSkill or SAPIEN pose) moved by (dx, dy, dz) in its parent's frame and turned by (roll, pitch, yaw)
    about its own x, y, z axes; as a ManiSkill pose."""
    import sapien
    from mani_skill.utils.structs.pose import Pose
    from transforms3d.euler import euler2quat

    from robolab_ms.catalog.procedural import quat_multiply

    base = pose.sp if hasattr(pose, "sp") else pose
    dx, dy, dz, roll, pitch, yaw = offsets
    turn = euler2quat(roll, pitch, yaw, "sxyz")
    moved = sapien.Pose(p=[base.p[0] + dx, base.p[1] + dy, base.p[2] + dz], q=quat_multiply(base.q, turn))
    return Pose.create(moved)


def _stream(seed: int, camera: str, offset: str):
    from robolab_ms.variations.base import stream

    return stream(seed, "camera", camera, offset)
