"""EvalContext: what predicates may ask of the simulation during one evaluate() call, computed once and cached."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch
from scipy.spatial import ConvexHull

from robolab_ms.catalog import CatalogObject

if TYPE_CHECKING:
    from mani_skill.envs.scene import ManiSkillScene
    from mani_skill.utils.structs import Actor, Link

OPEN_TOP_NORMAL_Z = 0.7  # hull faces whose normal points this far up are dropped: the column above the rim counts


def open_top_hull_planes(points: np.ndarray) -> np.ndarray:
    """Planes (n, d) of the convex hull of `points`, without its upward-facing faces; inside means n . x + d <= 0."""
    equations = ConvexHull(points).equations
    return equations[equations[:, 2] < OPEN_TOP_NORMAL_Z]


class EvalContext:
    """Per-step view of the scene for predicates. Call `refresh()` once per evaluate()."""

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
        self._planes: dict[str, torch.Tensor] = {}
        self._centres = {
            name: torch.as_tensor(entry.bounds.mean(axis=0), dtype=torch.float32, device=device)
            for name, entry in entries.items()
        }
        self._entity_names = {}
        for name, actor in actors.items():
            for entity in actor._objs:
                self._entity_names[entity] = name
        for link in finger_links:
            for body in link._objs:
                self._entity_names[body.entity] = "gripper"
        self._forces: dict[tuple[str, str], torch.Tensor] | None = None

    def refresh(self) -> None:
        """Forget the cached contact forces; the next query reads the new state."""
        self._forces = None

    # ------------------------------------------------------------------------------------------------- geometry
    def container_planes(self, container: str) -> torch.Tensor:
        if container not in self._planes:
            planes = open_top_hull_planes(self.entries[container].points)
            self._planes[container] = torch.as_tensor(planes, dtype=torch.float32, device=self.device)
        return self._planes[container]

    def centre_in_frame(self, name: str, frame: str) -> torch.Tensor:
        """The centre of object `name` in the frame of object `frame`: (num_envs, 3)."""
        world = self.centre(name)
        pose = self.actors[frame].pose
        rotation = pose.to_transformation_matrix()[:, :3, :3]
        return torch.einsum("eji,ej->ei", rotation, world - pose.p)

    def centre(self, name: str) -> torch.Tensor:
        """World position of the centre of the object's bounding box: (num_envs, 3)."""
        pose = self.actors[name].pose
        rotation = pose.to_transformation_matrix()[:, :3, :3]
        return pose.p + rotation @ self._centres[name]

    # ------------------------------------------------------------------------------------------------- contacts
    def contact_force(self, a: str, b: str) -> torch.Tensor:
        """Magnitude of the contact force between two named bodies ('gripper' = any finger): (num_envs,)."""
        if self.scene.gpu_sim_enabled:
            return self._gpu_contact_force(a, b)
        forces = self._cpu_contact_forces()
        zero = torch.zeros(self.scene.num_envs, device=self.device)
        return forces.get((a, b) if a <= b else (b, a), zero)

    def touches_gripper(self, name: str) -> torch.Tensor:
        from robolab_ms.tasks.predicates import CONTACT_FORCE_N

        return self.contact_force(name, "gripper") > CONTACT_FORCE_N

    def _bodies(self, name: str) -> list:
        return list(self.finger_links) if name == "gripper" else [self.actors[name]]

    def _gpu_contact_force(self, a: str, b: str) -> torch.Tensor:
        total = torch.zeros(self.scene.num_envs, device=self.device)
        for body_a in self._bodies(a):
            for body_b in self._bodies(b):
                total += torch.linalg.norm(self.scene.get_pairwise_contact_forces(body_a, body_b), dim=-1)
        return total

    def _cpu_contact_forces(self) -> dict[tuple[str, str], torch.Tensor]:
        """Summed force magnitude per pair of named bodies, from one pass over the contact list per step."""
        if self._forces is not None:
            return self._forces
        impulses: dict[tuple[str, str], np.ndarray] = {}
        for contact in self.scene.px.get_contacts():
            a = self._entity_names.get(contact.bodies[0].entity)
            b = self._entity_names.get(contact.bodies[1].entity)
            if a is None or b is None:
                continue
            total = sum((point.impulse for point in contact.points), np.zeros(3))
            key, sign = ((a, b), 1.0) if a <= b else ((b, a), -1.0)  # one orientation per pair
            impulses[key] = impulses.get(key, np.zeros(3)) + sign * total
        timestep = self.scene.px.timestep
        self._forces = {
            key: torch.tensor([np.linalg.norm(value) / timestep], dtype=torch.float32, device=self.device)
            for key, value in impulses.items()
        }
        return self._forces
