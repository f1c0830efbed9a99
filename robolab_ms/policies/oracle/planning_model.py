"""The robot model the oracle's planner checks collisions with: ManiSkill's Panda arm, its hand replaced by the
gripper's solids (`gripper.HAND_SOLIDS`) placed at the robot's TCP, as far as they lie in front of the flange
(behind it, the wrist is the arm's own links in the model).

The planner moves the flange and knows nothing of the hand on it but its collision geometry, so the geometry must be
the hand the robot carries: with ManiSkill's Panda hand (10 cm from the flange to the fingertips) a sampled joint path
could run DROID's 2F-85 (16 cm) through a shelf board. The model is written once per distinct content into the
cache folder, next to the combined DROID URDF.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robolab_ms.agents.droid_model import absolute_meshes, cached_file, panda_model, robot_cache_dir
from robolab_ms.policies.oracle.geometry import quat_to_matrix
from robolab_ms.policies.oracle.gripper import HAND_SAMPLE, HAND_SOLIDS

HAND_LINK = "panda_hand"  # the link that carries the hand's solids; the SRDF already exempts it from the wrist links
HAND_JOINT = "panda_hand_joint"  # fixed, from the flange to HAND_LINK
FINGER_LINKS = ("panda_leftfinger", "panda_rightfinger")  # their collision geometry is dropped (inside the solids)


def planning_urdf(tcp_in_flange: np.ndarray) -> Path:
    """Path of the planning URDF for a robot whose TCP sits at `tcp_in_flange` ([x, y, z, qw, qx, qy, qz] in the
    flange frame): the Panda's links and joints, the hand's collision geometry the gripper's solid boxes."""
    urdf, _ = panda_model()
    root = ET.parse(urdf).getroot()
    absolute_meshes(root, urdf.parent)
    for mesh in root.iter("mesh"):  # mplib reads mesh paths relative to the URDF's folder, absolute ones too
        mesh.set("filename", os.path.relpath(mesh.get("filename"), robot_cache_dir()))
    joint = next(element for element in root.iter("joint") if element.get("name") == HAND_JOINT)
    hand_in_flange = _origin_matrix(joint.find("origin"))
    tcp = np.eye(4)
    tcp[:3, :3] = quat_to_matrix(np.asarray(tcp_in_flange[3:]))
    tcp[:3, 3] = tcp_in_flange[:3]
    tcp_in_hand = np.linalg.inv(hand_in_flange) @ tcp
    flange_depth = float(tcp[:3, 2] @ tcp[:3, 3])  # m from the flange to the TCP along the hand's axis
    for link in root.iter("link"):
        if link.get("name") in (HAND_LINK, *FINGER_LINKS):
            for collision in link.findall("collision"):
                link.remove(collision)
        if link.get("name") == HAND_LINK:
            for half_x, half_y, z_from, z_to in HAND_SOLIDS:
                z_from = max(z_from, -flange_depth)  # behind the flange: the wrist, the arm's own links in the model
                if z_to - z_from < HAND_SAMPLE:  # nothing left, or a slab thinner than the hand is sampled at
                    continue
                link.append(_box(tcp_in_hand, (half_x, half_y, (z_to - z_from) / 2), (z_from + z_to) / 2))
    ET.indent(root)
    return cached_file("panda_planning", ".urdf", ET.tostring(root, encoding="unicode"))


def _origin_matrix(origin: ET.Element) -> np.ndarray:
    """The 4x4 transform of a URDF `origin` element (xyz, fixed-axis rpy)."""
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", [float(v) for v in origin.get("rpy", "0 0 0").split()]).as_matrix()
    matrix[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    return matrix


def _box(tcp_in_link: np.ndarray, half: tuple[float, float, float], tcp_z: float) -> ET.Element:
    """A URDF collision box with half extents `half` along the TCP's axes, its middle `tcp_z` along the TCP's z."""
    middle = tcp_in_link[:3, :3] @ np.array([0.0, 0.0, tcp_z]) + tcp_in_link[:3, 3]
    roll_pitch_yaw = Rotation.from_matrix(tcp_in_link[:3, :3]).as_euler("xyz")
    collision = ET.Element("collision")
    ET.SubElement(
        collision,
        "origin",
        xyz=" ".join(f"{v:.6f}" for v in middle),
        rpy=" ".join(f"{v:.6f}" for v in roll_pitch_yaw),
    )
    ET.SubElement(ET.SubElement(collision, "geometry"), "box", size=" ".join(f"{2 * v:.6f}" for v in half))
    return collision
