"""The spatial solver keeps an open container further from a pile whose top objects sit high than from a pile
standing flat on the table: an object knocked off its perch should land on the table, not in the container."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from robolab_ms.catalog import load_catalog
from robolab_ms.generation.proposal import read_proposal
from robolab_ms.generation.solver import GAP, rotation2, separation, solve_layout
from robolab_ms.scene.outlines import outline_points


@pytest.fixture(scope="module")
def catalog():
    return load_catalog()


def _gap_between(layout, catalog, first: str, second: str) -> float:
    poses = {pose.name: pose for pose in layout.poses}

    def polygon(name: str) -> np.ndarray:
        pose = poses[name]
        points = outline_points(catalog[pose.asset])[:, :2] @ rotation2(pose.yaw).T + np.array(pose.xy)
        return points[ConvexHull(points).vertices]

    return -separation(polygon(first), polygon(second))[0]


def _layout(catalog, stacked: bool):
    objects = [
        {"name": "big", "asset": "cube_large"},
        {"name": "small", "asset": "cube_medium"},
        {"name": "bin", "asset": "grey_bin"},
    ]
    relations = [{"relation": "left_of", "object": "bin", "reference": "big"}]
    if stacked:
        relations.append({"relation": "stacked", "objects": ["big", "small"]})
    else:
        relations.append({"relation": "right_of", "object": "small", "reference": "big"})
    proposal = read_proposal({"objects": objects, "relations": relations}, catalog)
    assert not proposal.problems
    layout = solve_layout(proposal, catalog)
    assert not layout.problems and not layout.relaxed
    return layout


def test_a_perched_object_keeps_its_height_from_an_open_container(catalog):
    perch = float(catalog["cube_large"].dimensions[2])  # the small cube sits on the big one's top
    gap = _gap_between(_layout(catalog, stacked=True), catalog, "big", "bin")
    assert gap >= 0.75 * perch > GAP


def test_a_flat_pile_keeps_the_usual_gap_from_a_container(catalog):
    gap = _gap_between(_layout(catalog, stacked=False), catalog, "big", "bin")
    assert GAP - 0.011 <= gap < 0.06
