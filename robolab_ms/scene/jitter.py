"""Per-episode jitter of a scene's objects that keeps neighbours apart.

Each pile (an object standing on the table with whatever rests on it) moves by up to the scene's `jitter.xy` along x
and y and turns by up to `jitter.yaw_deg`. Drawn independently, two neighbours can be pushed into each other: the
simulator then shoves them apart in the first steps and an apple rolls off a keyboard or a pile of cubes topples.
JitterSampler redraws the piles that come too close, so that seen from above no two piles come closer than they are
at their nominal places or JITTER_CLEARANCE, whichever is less; an object standing inside a container's outline
stays inside it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull

from robolab_ms.catalog import Catalog
from robolab_ms.catalog.procedural import quat_to_matrix
from robolab_ms.scene.outlines import outline_inside, outline_points, outlines_overlap
from robolab_ms.scene.spec import OVERLAP_TOLERANCE, SceneSpec

JITTER_CLEARANCE = 0.005  # m: piles nominally further apart than this stay at least this far apart
NARROWING_DRAWS = 20  # redraws over which the range of a pile that keeps meeting its neighbours shrinks to nothing


class JitterSampler:
    """Draws one episode's jitter for every object of a scene: offsets (N, 2) in metres and turns (N,) in radians,
    in scene order; an object resting on another uses the draw of the object at the bottom of its pile."""

    def __init__(self, spec: SceneSpec, catalog: Catalog):
        self.spec = spec
        self.names = spec.object_names()
        index = {name: position for position, name in enumerate(self.names)}
        self.base_of = np.array([index[spec.base(name)] for name in self.names])
        placements = spec.objects
        self.xy = np.array([placement.xy for placement in placements])
        self.yaw = np.array([placement.yaw for placement in placements])
        self.outlines = []  # each object's outline seen from above, tilted as it rests, before its yaw (object frame)
        for placement in placements:
            points = outline_points(catalog[placement.asset]) @ quat_to_matrix(tuple(placement.tilt))[:2].T
            self.outlines.append(points[ConvexHull(points).vertices])
        self.is_container = [catalog[placement.asset].is_container for placement in placements]
        self.still = {position for position, placement in enumerate(placements) if placement.fixture}  # shelves
        nominal = self.footprints(np.zeros((len(self.names), 2)), np.zeros(len(self.names)))
        self.pairs = []  # (i, j, kind, allowed overlap) for objects of different piles that could meet
        for i in range(len(self.names)):
            for j in range(i):
                if self.base_of[i] == self.base_of[j]:
                    continue
                containment = self._containment(nominal, i, j)
                if containment is not None:
                    self.pairs.append((containment[0], containment[1], "inside", 0.0))
                    continue
                allowed = max(outlines_overlap(nominal[i], nominal[j]), -JITTER_CLEARANCE)
                self.pairs.append((i, j, "apart", allowed))

    def _containment(self, outlines: list[np.ndarray], i: int, j: int) -> tuple[int, int] | None:
        """(inner, outer) when one object stands inside the other's container outline at the nominal places."""
        for inner, outer in ((i, j), (j, i)):
            if self.is_container[outer] and outline_inside(outlines[inner], outlines[outer], OVERLAP_TOLERANCE):
                return inner, outer
        return None

    def footprints(self, offsets: np.ndarray, turns: np.ndarray) -> list[np.ndarray]:
        """Every object's outline seen from above (world x, y) with its pile moved by `offsets` and turned by
        `turns` (per object, read at each pile's bottom object)."""
        shapes = []
        for position, base in enumerate(self.base_of):
            turn = turns[base]
            arm = self.xy[position] - self.xy[base]
            c, s = math.cos(turn), math.sin(turn)
            centre = self.xy[base] + np.array([c * arm[0] - s * arm[1], s * arm[0] + c * arm[1]]) + offsets[base]
            yaw = self.yaw[position] + turn
            c, s = math.cos(yaw), math.sin(yaw)
            shapes.append(self.outlines[position] @ np.array([[c, s], [-s, c]]) + centre)
        return shapes

    def conflicts(self, offsets: np.ndarray, turns: np.ndarray) -> set[int]:
        """The piles (their bottom objects' indices) that come too close to another pile at this jitter."""
        shapes = self.footprints(offsets, turns)
        low = np.array([shape.min(axis=0) for shape in shapes])
        high = np.array([shape.max(axis=0) for shape in shapes])
        crowded: set[int] = set()
        for i, j, kind, allowed in self.pairs:
            if kind == "inside":
                if not outline_inside(shapes[i], shapes[j], OVERLAP_TOLERANCE):
                    crowded.update((int(self.base_of[i]), int(self.base_of[j])))
                continue
            if ((np.minimum(high[i], high[j]) - np.maximum(low[i], low[j])) <= allowed).any():
                continue  # the bounding boxes alone keep them far enough apart
            if outlines_overlap(shapes[i], shapes[j]) > allowed + 1e-9:
                crowded.update((int(self.base_of[i]), int(self.base_of[j])))
        return crowded

    def draw(self, rng: np.random.RandomState) -> tuple[np.ndarray, np.ndarray]:
        """One episode's offsets (N, 2) and turns (N,): a first draw for every object in scene order, then redraws
        of the piles that meet a neighbour, over a range that narrows with each redraw to the nominal place."""
        count = len(self.names)
        offsets, turns = np.zeros((count, 2)), np.zeros(count)
        xy_range, yaw_range = self.spec.jitter_xy, self.spec.jitter_yaw
        for position in range(count):  # one draw per object, whether it is used or not
            offsets[position] = rng.uniform(-xy_range, xy_range, size=(2,))
            turns[position] = rng.uniform(-yaw_range, yaw_range, size=(1,))[0]
        for position in self.still:  # a fixture stays where the scene file puts it
            offsets[position], turns[position] = 0.0, 0.0
        redraws = 0
        crowded = self.conflicts(offsets, turns)
        while crowded:
            redraws += 1
            scale = max(0.0, 1.0 - redraws / NARROWING_DRAWS)
            for pile in sorted(crowded - self.still):
                offsets[pile] = rng.uniform(-xy_range, xy_range, size=(2,)) * scale
                turns[pile] = rng.uniform(-yaw_range, yaw_range, size=(1,))[0] * scale
            crowded = self.conflicts(offsets, turns)
        return offsets, turns
