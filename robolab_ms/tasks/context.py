"""EvalContext: what predicates ask of the simulation in one evaluate() call, each quantity read once per step.

Everything returned has a leading `num_envs` dimension. Poses, contact forces and predicate results are cached
until `refresh()`, which evaluate() calls once per control step; stateful predicates keep per-episode memory in
`memory()`, cleared by `reset()`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from scipy.spatial import ConvexHull

from robolab_ms.catalog import CatalogObject

if TYPE_CHECKING:
    from mani_skill.envs.scene import ManiSkillScene
    from mani_skill.utils.structs import Actor, Link

OPEN_TOP_NORMAL_Z = 0.7  # hull faces whose normal points this far up are dropped: the column above the rim counts
GRIPPER = "gripper"  # the name under which every finger link of the robot is known


def hull_planes(points: np.ndarray, open_top: bool) -> np.ndarray:
    """Planes (n, d) of the convex hull of `points` (inside: n . x + d <= 0), optionally without upward faces."""
    equations = ConvexHull(points).equations
    return equations[equations[:, 2] < OPEN_TOP_NORMAL_Z] if open_top else equations


class EvalContext:
    """Per-step, cached view of the scene for predicates and events."""

    def __init__(
        self,
        scene: ManiSkillScene,
        actors: dict[str, Actor],
        entries: dict[str, CatalogObject],
        finger_links: list[Link],
        device: torch.device,
    ) -> None:
        self.scene = scene
        self.actors = actors
        self.entries = entries
        self.finger_links = finger_links
        self.device = device
        self.num_envs = scene.num_envs
        self._geometry: dict[tuple, torch.Tensor] = {}
        self._entity_names: dict[Any, str] = {}
        for name, actor in actors.items():
            for entity in actor._objs:
                self._entity_names[entity] = name
        self._fingers = [f"{GRIPPER}:{index}" for index in range(len(finger_links))]
        for finger, link in zip(self._fingers, finger_links):
            for body in link._objs:
                self._entity_names[body.entity] = finger
        self._step_cache: dict[Any, Any] = {}
        self._memory: dict[Any, torch.Tensor] = {}
        self.elapsed_steps = torch.zeros(self.num_envs, dtype=torch.long, device=device)

    # ------------------------------------------------------------------------------------------------ caching
    def refresh(self, elapsed_steps: torch.Tensor | None = None) -> None:
        """Forget everything read from the simulation; call once per evaluate() with the env's step counter."""
        self._step_cache.clear()
        if elapsed_steps is not None:
            self.elapsed_steps = elapsed_steps.to(torch.long)

    def cached(self, key: Any, compute: Callable[[], Any]) -> Any:
        """`compute()` once per step for `key`."""
        if key not in self._step_cache:
            self._step_cache[key] = compute()
        return self._step_cache[key]

    def memory(self, key: Any, initial: Callable[[], torch.Tensor]) -> torch.Tensor:
        """A tensor that lives across steps (e.g. placement order); `reset()` zeroes the rows of new episodes."""
        if key not in self._memory:
            self._memory[key] = initial()
        return self._memory[key]

    def reset(self, env_idx: torch.Tensor) -> None:
        """Start new episodes in `env_idx`: clear their memory."""
        self.refresh()
        for value in self._memory.values():
            value[env_idx] = 0

    # ------------------------------------------------------------------------------------------------ poses
    def position(self, name: str) -> torch.Tensor:
        """World position of the object's frame origin: (E, 3)."""
        return self._pose(name)[0]

    def rotation(self, name: str) -> torch.Tensor:
        """World rotation matrix of the object: (E, 3, 3)."""
        return self._pose(name)[1]

    def _pose(self, name: str) -> tuple[torch.Tensor, torch.Tensor]:
        def read():
            pose = self.actors[name].pose
            return pose.p, pose.to_transformation_matrix()[:, :3, :3]

        return self.cached(("pose", name), read)

    def up_axis(self, name: str) -> torch.Tensor:
        """The object's own z axis in the world: (E, 3)."""
        return self.rotation(name)[:, :, 2]

    def centre(self, name: str) -> torch.Tensor:
        """World position of the centre of the object's bounding box: (E, 3)."""
        return self.cached(("centre", name), lambda: self.to_world(name, self._local_centre(name))[:, 0])

    def corners(self, name: str) -> torch.Tensor:
        """World positions of the 8 corners of the object's bounding box: (E, 8, 3)."""
        return self.cached(("corners", name), lambda: self.to_world(name, self._local_corners(name)))

    def to_world(self, name: str, local: torch.Tensor) -> torch.Tensor:
        """Object-frame points (P, 3) to world points (E, P, 3)."""
        return torch.einsum("eij,pj->epi", self.rotation(name), local) + self.position(name)[:, None, :]

    def in_frame(self, points: torch.Tensor, name: str) -> torch.Tensor:
        """World points (E, P, 3) to the frame of object `name`."""
        return torch.einsum("eji,epj->epi", self.rotation(name), points - self.position(name)[:, None, :])

    def top_z(self, name: str) -> torch.Tensor:
        """Height of the highest bounding-box corner: (E,)."""
        return self.corners(name)[:, :, 2].max(dim=1).values

    def footprint(self, name: str) -> tuple[torch.Tensor, torch.Tensor]:
        """World x-y bounds of the object's bounding box: (E, 2) low, (E, 2) high."""
        xy = self.corners(name)[:, :, :2]
        return xy.min(dim=1).values, xy.max(dim=1).values

    def linear_speed(self, name: str) -> torch.Tensor:
        return self.cached(("speed", name), lambda: torch.linalg.norm(self.actors[name].linear_velocity, dim=-1))

    # ------------------------------------------------------------------------------------------------ geometry
    def _local_centre(self, name: str) -> torch.Tensor:
        return self._static(("centre", name), lambda: self.entries[name].bounds.mean(axis=0, keepdims=True))

    def _local_corners(self, name: str) -> torch.Tensor:
        low, high = self.entries[name].bounds
        return self._static(("corners", name), lambda: np.array(
            [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]))

    def container_planes(self, name: str, open_top: bool = True) -> torch.Tensor:
        """Hull planes (P, 4) of a container in its own frame; open_top drops the faces that look up."""
        return self._static(("planes", name, open_top), lambda: hull_planes(self.entries[name].points, open_top))

    def _static(self, key: tuple, compute: Callable[[], np.ndarray]) -> torch.Tensor:
        if key not in self._geometry:
            self._geometry[key] = torch.as_tensor(compute(), dtype=torch.float32, device=self.device)
        return self._geometry[key]

    # ------------------------------------------------------------------------------------------------ contacts
    def force_on(self, a: str, b: str) -> torch.Tensor:
        """Contact force on `a` from `b` (N), world frame: (E, 3). `gripper` stands for all finger links."""
        if GRIPPER in (a, b):
            other = b if a == GRIPPER else a
            net = sum(self.force_on(finger, other) for finger in self._fingers)
            return net if a == GRIPPER else -net
        if self.scene.gpu_sim_enabled:
            return self.cached(("gpu_force", a, b), lambda: self._gpu_force(a, b))
        forces = self.cached("cpu_forces", self._cpu_forces)
        if a <= b:
            return forces.get((a, b), self._zero3())
        return -forces.get((b, a), self._zero3())

    def contact_force(self, a: str, b: str) -> torch.Tensor:
        """Magnitude of the contact force between `a` and `b`: (E,). With `gripper`, the fingers' forces add up
        (two fingers squeezing push in opposite directions: their net force says nothing about contact)."""
        if GRIPPER in (a, b):
            other = b if a == GRIPPER else a
            return sum(torch.linalg.norm(self.force_on(finger, other), dim=-1) for finger in self._fingers)
        return torch.linalg.norm(self.force_on(a, b), dim=-1)

    def _zero3(self) -> torch.Tensor:
        return torch.zeros(self.num_envs, 3, device=self.device)

    def _body(self, name: str):
        if name in self._fingers:
            return self.finger_links[self._fingers.index(name)]
        return self.actors[name]

    def _gpu_force(self, a: str, b: str) -> torch.Tensor:
        return self.scene.get_pairwise_contact_forces(self._body(a), self._body(b))

    def _cpu_forces(self) -> dict[tuple[str, str], torch.Tensor]:
        """Force per pair of named bodies (key sorted; value = force on the first), from one pass over contacts."""
        impulses: dict[tuple[str, str], np.ndarray] = {}
        for contact in self.scene.px.get_contacts():
            a = self._entity_names.get(contact.bodies[0].entity)
            b = self._entity_names.get(contact.bodies[1].entity)
            if a is None or b is None or a == b:
                continue
            total = np.zeros(3)
            for point in contact.points:
                total += point.impulse  # the impulse on bodies[0]
            key, sign = ((a, b), 1.0) if a <= b else ((b, a), -1.0)
            impulses[key] = impulses.get(key, 0.0) + sign * total
        timestep = self.scene.px.timestep
        return {key: torch.as_tensor(value / timestep, dtype=torch.float32, device=self.device).reshape(1, 3)
                for key, value in impulses.items()}  # fmt: skip
