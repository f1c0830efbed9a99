"""Every shipped scene of RoboLab's is RoboLab's layout (tests/fixtures/robolab120/scenes.csv): the same bodies
under the same names, each at RoboLab's x, y (within 1 cm) and lying where RoboLab's lies, unless the scene file's
header says otherwise for that body; and docs/robolab_scenes.md lists exactly those changes. No simulation."""

from __future__ import annotations

import csv
import math
import re
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from robolab_ms.catalog import load_catalog
from robolab_ms.catalog.procedural import quat_multiply, quat_to_matrix, yaw_quat
from robolab_ms.scene import load_scene, scene_files

REFERENCE = Path(__file__).parent / "fixtures" / "robolab120" / "scenes.csv"
DOCS = Path(__file__).parent.parent / "docs" / "robolab_scenes.md"
PLACE_TOLERANCE = 0.01  # m: x, y of a body the scene file does not say it moved
MOVE_TOLERANCE = 0.01  # m: how far a stated "moved N cm" may be from the true distance
PARKED_BELOW = -1.0  # m: RoboLab parks unused bodies far below the floor; they are not in its scene
SIMILAR = 1.25  # extents within this factor cannot tell lying from standing


def reference_layouts() -> dict[str, dict[str, dict]]:
    """RoboLab's bodies by scene and name (parked ones left out)."""
    layouts: dict[str, dict[str, dict]] = defaultdict(dict)
    with open(REFERENCE, newline="") as file:
        for row in csv.DictReader(file):
            if float(row["z"]) > PARKED_BELOW:
                layouts[row["scene"]][row["name"]] = row
    return layouts


LAYOUTS = reference_layouts()


def stated_changes(scene: str) -> dict[str, str]:
    """The scene file's header comments `# body: what differs from RoboLab`, by body."""
    changes = {}
    for line in scene_files()[scene].read_text(encoding="utf-8").splitlines():
        match = re.fullmatch(r"# (\w+): (.+)", line)
        if match:
            changes[match[1]] = match[2]
    return changes


def vertical_rank(dimensions: np.ndarray, rotation: np.ndarray) -> int:
    """Which of an object's extents points up (0 the smallest, 2 the largest): 0 lies flat, 2 stands tall."""
    up_axis = int(np.argmax(np.abs(rotation[2])))  # the model axis closest to the world's z
    return int(np.argsort(np.argsort(dimensions, kind="stable"), kind="stable")[up_axis])


def same_resting_side(theirs: np.ndarray, their_rank: int, ours: np.ndarray, our_rank: int) -> bool:
    """The same extent points up, or the extents in question are too alike to tell (a cube, a round fruit)."""
    if their_rank == our_rank:
        return True
    theirs, ours = np.sort(theirs), np.sort(ours)
    return max(theirs[their_rank], theirs[our_rank]) <= SIMILAR * min(theirs[their_rank], theirs[our_rank]) or max(
        ours[their_rank], ours[our_rank]
    ) <= SIMILAR * min(ours[their_rank], ours[our_rank])


def test_the_reference_covers_every_shipped_scene_but_our_own():
    assert sorted(set(scene_files()) - set(LAYOUTS)) == ["kitchen_table"]  # our own 20-object scene


@pytest.mark.parametrize("scene_name", sorted(LAYOUTS))
def test_scene_is_robolabs_layout(scene_name):
    if scene_name not in scene_files():
        pytest.skip(f"{scene_name} is not shipped yet")
    scene, catalog, reference = load_scene(scene_name), load_catalog(), LAYOUTS[scene_name]
    changes = stated_changes(scene_name)
    assert sorted(scene.object_names()) == sorted(reference), "not RoboLab's bodies"
    assert set(changes) <= set(reference), f"comments name bodies that are not in the scene: {changes}"
    problems = []
    for placement in scene.objects:
        row = reference[placement.name]
        change = changes.get(placement.name, "")
        distance = math.dist(placement.xy, (float(row["x"]), float(row["y"])))
        moved = re.search(r"moved ([\d.]+) cm", change)
        if moved and abs(distance - float(moved[1]) / 100) > MOVE_TOLERANCE:
            problems.append(
                f"{placement.name}: {distance * 100:.1f} cm from RoboLab's place, its comment says {moved[1]} cm"
            )
        if not moved and distance > PLACE_TOLERANCE:
            problems.append(f"{placement.name}: {distance * 100:.1f} cm from RoboLab's place, and no comment says so")
        other_changes = [clause for clause in change.split("; ") if clause and not clause.startswith("moved ")]
        if other_changes or not row["dim_x"]:  # a stated change of pose, or RoboLab lists no size
            continue
        their_dimensions = np.array([float(row[key]) for key in ("dim_x", "dim_y", "dim_z")])
        their_rotation = quat_to_matrix(tuple(float(row[key]) for key in ("qw", "qx", "qy", "qz")))
        our_dimensions = catalog[placement.asset].dimensions
        our_rotation = quat_to_matrix(tuple(quat_multiply(yaw_quat(placement.yaw), placement.tilt)))
        their_rank = vertical_rank(their_dimensions, their_rotation)
        our_rank = vertical_rank(our_dimensions, our_rotation)
        if not same_resting_side(their_dimensions, their_rank, our_dimensions, our_rank):
            sides = ("flat", "on its side", "upright")
            problems.append(
                f"{placement.name}: RoboLab's rests {sides[their_rank]}, ours {sides[our_rank]}, and no comment says so"
            )
    assert not problems, "\n".join(problems)


def test_docs_list_every_stated_change():
    """docs/robolab_scenes.md's table of changes holds the scene files' comments, no more and no fewer."""
    listed = set()
    for line in DOCS.read_text(encoding="utf-8").splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0] in LAYOUTS:
            listed.add(tuple(cells))
    stated = {
        (scene, body, change)
        for scene in LAYOUTS
        if scene in scene_files()
        for body, change in stated_changes(scene).items()
    }
    assert stated - listed == set(), "changes the docs do not list"
    assert listed - stated == set(), "changes the docs list that the scene files do not state"
