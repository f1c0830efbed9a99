"""The Panda arm's reach: flange poses that no posture of the arm puts the flange at, told from the arm's geometry
alone, so that inverse kinematics need not search them (out of reach, every one of its starts runs to its last
iteration).

The origin of the first link lies on the axes of the first two joints, so it never moves: the shoulder. The origin
of the sixth link, the wrist, is as far from the shoulder as the elbow (the fourth joint) alone makes it, at most
`ArmReach.reach`. The flange pose fixes the last joint's axis and the origin of the last link on it; the wrist lies
on a circle about that axis, centred on that origin (`wrist_radius` across). A pose whose circle stays farther from
the shoulder than the reach everywhere is out of reach.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.geometry import quat_to_matrix

SHOULDER_LINK = "panda_link1"  # its origin lies on the axes of the first two joints
WRIST_LINK = "panda_link6"  # its origin: the wrist
LAST_LINK = "panda_link7"  # the link the last joint turns, about its z axis
ELBOW = 3  # index of the elbow (panda_joint4) among the planning model's joints
ELBOW_SAMPLES = 3001  # elbow angles over its range at which the shoulder-to-wrist distance is measured
REACH_MARGIN = 3e-3  # m a pose may lie beyond the reach and still be returned by inverse kinematics: a solution
# may miss its pose by the tolerance (1e-3, metres plus quaternion difference), which moves the wrist's circle by
# under 2 mm


@dataclass(frozen=True)
class ArmReach:
    """The geometry the test needs, in the planning model's base frame."""

    shoulder: np.ndarray  # (3,) position of the shoulder
    last_in_flange: np.ndarray  # (4, 4) pose of the last link in the flange's frame
    wrist_radius: float  # m from the last joint's axis to the wrist
    reach: float  # m: the largest distance from the shoulder to the wrist

    @classmethod
    def of(cls, planner: Any, flange_link: str) -> ArmReach:
        """The reach of the arm of mplib planner `planner`, whose move group ends at `flange_link`."""
        model, index = planner.pinocchio_model, planner.link_name_2_idx
        lower, upper = np.asarray(planner.joint_limits, dtype=np.float64).T

        def poses(qpos: np.ndarray) -> dict[str, np.ndarray]:
            model.compute_forward_kinematics(qpos)
            return {link: _matrix(model.get_link_pose(index[link])) for link in (SHOULDER_LINK, WRIST_LINK, LAST_LINK)}

        qpos = np.clip(np.zeros(len(lower)), lower, upper)
        distances = []
        for elbow in np.linspace(lower[ELBOW], upper[ELBOW], ELBOW_SAMPLES):
            qpos[ELBOW] = elbow
            at = poses(qpos)
            distances.append(np.linalg.norm(at[WRIST_LINK][:3, 3] - at[SHOULDER_LINK][:3, 3]))
        # the model still holds the forward kinematics of the last elbow angle, the one `at` was read at
        flange = _matrix(model.get_link_pose(index[flange_link]))
        last = at[LAST_LINK]
        offset = last[:3, 3] - at[WRIST_LINK][:3, 3]
        if abs(float(offset @ last[:3, 2])) > 1e-6:
            raise OracleFailure("the arm's wrist is not square to its last joint's axis: ArmReach does not hold")
        return cls(
            shoulder=at[SHOULDER_LINK][:3, 3].copy(),
            last_in_flange=np.linalg.inv(flange) @ last,
            wrist_radius=float(np.linalg.norm(offset)),
            reach=float(max(distances)),
        )

    def beyond(self, flange_pose: np.ndarray) -> float:
        """How far (m) flange pose `flange_pose` [x, y, z, qw, qx, qy, qz] lies out of the arm's reach: the nearest
        the wrist can come to the shoulder there, less the reach; zero or less where a posture may reach it."""
        last = _matrix(flange_pose) @ self.last_in_flange
        axis, centre = last[:3, 2], last[:3, 3] - self.shoulder
        along = float(centre @ axis)
        across = float(np.linalg.norm(centre - along * axis))
        return float(np.hypot(along, across - self.wrist_radius)) - self.reach

    def out_of_reach(self, flange_pose: np.ndarray) -> bool:
        """Whether no posture of the arm puts the flange at `flange_pose` (with REACH_MARGIN to spare)."""
        return self.beyond(flange_pose) > REACH_MARGIN


def _matrix(pose: Any) -> np.ndarray:
    """A 4x4 transform from a pose [x, y, z, qw, qx, qy, qz]."""
    pose = np.asarray(pose, dtype=np.float64)
    matrix = np.eye(4)
    matrix[:3, :3] = quat_to_matrix(pose[3:])
    matrix[:3, 3] = pose[:3]
    return matrix
