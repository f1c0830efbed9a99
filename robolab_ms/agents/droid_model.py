"""The DROID robot model: ManiSkill's Franka Panda arm with a Robotiq 2F-85 gripper on its flange.

Nothing is copied into the repository: the arm comes from the installed `mani-skill` package (its Panda URDF and
meshes), the gripper from the installed `airo-models` package (MIT; URDF and meshes), and `droid_urdf_path()`
writes the combined URDF, which points at those installed meshes, into a cache folder on first use.
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from robolab_ms.errors import RoboLabError

ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FLANGE_LINK = "panda_link8"
COUPLING_LINK = "robotiq_coupling"
GRIPPER_BASE_LINK = "robotiq_base_link"
TCP_LINK = "robotiq_tcp"
DRIVEN_GRIPPER_JOINTS = ("left_outer_knuckle_joint", "right_outer_knuckle_joint")
PASSIVE_GRIPPER_JOINTS = (
    "left_inner_knuckle_joint",
    "right_inner_knuckle_joint",
    "left_inner_finger_joint",
    "right_inner_finger_joint",
)
FINGER_PAD_LINKS = ("left_inner_finger_pad", "right_inner_finger_pad")
FINGER_LINKS = ("left_inner_finger", "right_inner_finger")

DROID_HOME_ARM = (0.0, -math.pi / 5, 0.0, -4 * math.pi / 5, 0.0, 3 * math.pi / 5, 0.0)  # rad, DROID's home pose

# Panda limits used by DROID (FACTS section 2): position (rad), effort (Nm), velocity (rad/s), per arm joint.
ARM_LOWER = (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973)
ARM_UPPER = (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)
ARM_EFFORT = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
ARM_VELOCITY = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)

GRIPPER_CLOSED_RAD = 0.8  # outer knuckle angle of a closed 2F-85 (finger_joint's upper limit)
COUPLING_THICKNESS = 0.0139  # m, the Robotiq coupling between flange and gripper base (its mesh is 13.9 mm thick)
COUPLING_RADIUS = 0.0375
# The gripper base is turned about the flange axis so that the fingers close along the flange's y axis, as the
# Panda hand's fingers do at the same joint angles: at DROID's home pose they close along the world y axis.
GRIPPER_YAW = math.pi / 2
TCP_DEPTH = 0.143  # m from the gripper base along its axis: between the finger pads when they touch an object
OPEN_PAD_GAP = 0.086  # m between the finger pads of the open 2F-85 model (the oracle's hand geometry reads this)
RATED_OPENING_MARGIN = 0.001  # m the real 2F-85's rated 85-mm stroke is narrower than the model's open pads ...
RATED_OPENING = OPEN_PAD_GAP - RATED_OPENING_MARGIN  # ... the opening the catalog's "fits" column measures against

ROBOTIQ_URDF = "grippers/robotiq_2f_85/urdf/robotiq_2f_85.urdf"
INSTALL_HINT = "install the pinned dependencies: .venv/bin/pip install -r requirements.lock"


def package_dir(module: str) -> Path:
    """Folder of an installed package, found without importing it."""
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.submodule_search_locations:
        raise RoboLabError(f"the package '{module}' is not installed; {INSTALL_HINT}")
    return Path(next(iter(spec.submodule_search_locations)))


def cache_dir() -> Path:
    """Where generated robot files go: $ROBOLAB_MS_CACHE, else $XDG_CACHE_HOME/robolab_ms, else ~/.cache/robolab_ms."""
    if os.environ.get("ROBOLAB_MS_CACHE"):
        return Path(os.environ["ROBOLAB_MS_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "robolab_ms"


def absolute_meshes(root: ET.Element, urdf_folder: Path) -> None:
    """Point the meshes of a parsed URDF, given relative to `urdf_folder`, at their absolute paths."""
    for mesh in root.iter("mesh"):
        mesh.set("filename", str((urdf_folder / mesh.get("filename")).resolve()))


def panda_model() -> tuple[Path, Path]:
    """ManiSkill's Panda URDF and SRDF (arm, hand and collision pairs), in the installed mani-skill package."""
    base = package_dir("mani_skill") / "assets" / "robots" / "panda" / "panda_v2"
    return base.with_suffix(".urdf"), base.with_suffix(".srdf")


def _panda_arm() -> list[ET.Element]:
    """Links panda_link0..8 and their joints from ManiSkill's Panda, with DROID's limits."""
    urdf, _ = panda_model()
    root = ET.parse(urdf).getroot()
    absolute_meshes(root, urdf.parent)
    keep_links = {f"panda_link{i}" for i in range(9)}
    elements = []
    for element in root:
        if element.tag == "link" and element.get("name") in keep_links:
            elements.append(element)
        elif element.tag == "joint" and element.find("child").get("link") in keep_links:
            name = element.get("name")
            if name in ARM_JOINTS:
                i = ARM_JOINTS.index(name)
                limit = element.find("limit")
                limit.attrib.update(
                    lower=str(ARM_LOWER[i]),
                    upper=str(ARM_UPPER[i]),
                    effort=str(ARM_EFFORT[i]),
                    velocity=str(ARM_VELOCITY[i]),
                )
            elements.append(element)
    return elements


def _robotiq() -> list[ET.Element]:
    """The 2F-85's links and joints from airo-models: Drake tags and mimic tags removed (ManiSkill closes the
    linkage with drive constraints and a mimic controller instead), base renamed, driving joint named like its twin."""
    urdf = package_dir("airo_models") / ROBOTIQ_URDF
    if not urdf.is_file():
        raise RoboLabError(f"{urdf} is missing from airo-models; {INSTALL_HINT}")
    text = urdf.read_text()
    text = re.sub(r"<drake:(\w+)[^>]*/>", "", text)
    text = re.sub(r"<drake:(\w+)[^>]*>.*?</drake:\1>", "", text, flags=re.DOTALL)
    root = ET.fromstring(text)
    absolute_meshes(root, urdf.parent)
    renames = {"base_link": GRIPPER_BASE_LINK, "finger_joint": DRIVEN_GRIPPER_JOINTS[0]}
    elements = []
    for element in root:
        if element.tag not in ("link", "joint"):
            continue  # transmissions
        element.set("name", renames.get(element.get("name"), element.get("name")))
        for ref in [*element.findall("parent"), *element.findall("child")]:
            ref.set("link", renames.get(ref.get("link"), ref.get("link")))
        for mimic in element.findall("mimic"):
            element.remove(mimic)
        elements.append(element)
    return elements


def _fixed_joint(name: str, parent: str, child: str, xyz: tuple, rpy: tuple = (0.0, 0.0, 0.0)) -> ET.Element:
    joint = ET.Element("joint", name=name, type="fixed")
    ET.SubElement(joint, "origin", xyz=" ".join(map(str, xyz)), rpy=" ".join(map(str, rpy)))
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    return joint


def _coupling() -> list[ET.Element]:
    """The coupling disc (visual mesh from airo-models, a cylinder for collisions), the gripper mount and the TCP."""
    mesh = (
        package_dir("airo_models") / "grippers" / "robotiq_2f_85" / "meshes" / "visual" / "robotiq_gripper_coupling.obj"
    )
    link = ET.Element("link", name=COUPLING_LINK)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass", value="0.1")
    ET.SubElement(inertial, "inertia", ixx="4e-5", iyy="4e-5", izz="7e-5", ixy="0", ixz="0", iyz="0")
    visual = ET.SubElement(link, "visual")
    ET.SubElement(ET.SubElement(visual, "geometry"), "mesh", filename=str(mesh), scale="0.001 0.001 0.001")
    material = ET.SubElement(visual, "material", name="coupling")
    ET.SubElement(material, "color", rgba="0.15 0.15 0.15 1")
    collision = ET.SubElement(link, "collision")
    geometry = ET.SubElement(collision, "geometry")
    ET.SubElement(geometry, "cylinder", radius=str(COUPLING_RADIUS), length=str(COUPLING_THICKNESS))
    half = COUPLING_THICKNESS / 2
    return [
        link,
        _fixed_joint("robotiq_coupling_joint", FLANGE_LINK, COUPLING_LINK, (0, 0, half), (0, 0, GRIPPER_YAW)),
        _fixed_joint("robotiq_mount_joint", COUPLING_LINK, GRIPPER_BASE_LINK, (0, 0, half)),
        ET.Element("link", name=TCP_LINK),
        # the TCP frame follows ManiSkill's Panda: z along the fingers, y the closing direction
        _fixed_joint("robotiq_tcp_joint", GRIPPER_BASE_LINK, TCP_LINK, (0, 0, TCP_DEPTH), (0, 0, -math.pi / 2)),
    ]


def build_droid_urdf() -> str:
    """The combined Panda + coupling + Robotiq 2F-85 URDF, as text (mesh paths point into the installed packages)."""
    robot = ET.Element("robot", name="droid_panda_robotiq_2f_85")
    for element in _panda_arm() + _coupling() + _robotiq():
        robot.append(element)
    ET.indent(robot)
    return ET.tostring(robot, encoding="unicode")


def droid_urdf_path() -> Path:
    """Path of the combined URDF, written once per distinct content into the cache folder."""
    return cached_file("droid", ".urdf", build_droid_urdf())


def robot_cache_dir() -> Path:
    """The cache folder's subfolder for generated robot files."""
    return cache_dir() / "robots"


def cached_file(stem: str, suffix: str, text: str) -> Path:
    """Path of a generated robot file with content `text` in the cache folder, written once per distinct content
    (named `stem`, a digest of the content and `suffix`)."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = robot_cache_dir() / f"{stem}_{digest}{suffix}"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(f".{os.getpid()}.tmp")
        partial.write_text(text)
        partial.replace(path)  # atomic: parallel processes never read half a file
    return path


def linkage_anchors() -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Where each finger's four-bar linkage closes: a point in the inner knuckle's frame and the same point in the
    inner finger's frame (identical for both sides, whose frames mirror each other).

    The outer knuckle, inner knuckle and inner finger form a parallelogram, so the inner knuckle's free end sits at
    (outer knuckle pivot -> inner finger pivot) from its own pivot, which seen from the inner finger pivot is
    (outer knuckle pivot -> inner knuckle pivot); both read off the right side's joint origins at zero angle.
    """
    origin = {
        joint.get("name"): [float(v) for v in joint.find("origin").get("xyz").split()]
        for joint in _robotiq()
        if joint.tag == "joint"
    }
    outer_to_finger = [a + b for a, b in zip(origin["right_outer_finger_joint"], origin["right_inner_finger_joint"])]
    outer_to_inner = [b - a for a, b in zip(origin["right_outer_knuckle_joint"], origin["right_inner_knuckle_joint"])]
    return tuple(outer_to_finger), tuple(outer_to_inner)
