"""EvalContext: what predicates ask of the simulation in one evaluate() call, each quantity read once per step.

Everything returned has a leading `num_envs` dimension. Poses, contact forces and predicate results are cached
until `refresh()`, which evaluate() calls once per control step; stateful predicates keep per-episode memory in
`memory()`, cleared by `reset()`.

Products of vectors and matrices are written as broadcast multiply-and-sum, never as matmul / einsum: on the CPU
simulator a BLAS call made right after a physics step waits for PhysX's worker threads to free the cores
(measured: 0.74 ms instead of 0.02 ms for one batch of quaternion-to-matrix conversions). Likewise, extremes along
a dimension are taken with amin / amax, never min / max with indices: on a (1, 8, 2) tensor those take 26 us instead
of 3.5 us on one thread and up to 10 ms with two threads on a busy machine (PutMugsOnShelf's footprint of the rack)."""

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
        robot_links: list[Link] | None = None,
    ) -> None:
        """`robot_links`: every link of the robot, fingers included (default: the fingers), for `non_robot_forces`."""
        self.scene = scene
        self.actors = actors
        self.entries = entries
        self.finger_links = finger_links
        self.device = device
        self.num_envs = scene.num_envs
        self._geometry: dict[tuple, torch.Tensor] = {}
        # pairs whose forces have been asked for; the contact pass sums impulses only for these and finger pairs
        self._wanted_pairs: set[tuple[str, str]] = set()
        self._fingers = [f"{GRIPPER}:{index}" for index in range(len(finger_links))]
        self._step_cache: dict[Any, Any] = {}
        self._memory: dict[Any, torch.Tensor] = {}
        # all tracked bodies are read as one merged view: one pose query and one rotation conversion per step
        self.names = list(actors)
        self.index = {name: i for i, name in enumerate(self.names)}
        from mani_skill.utils.structs import Actor  # not at module level: spec checking must not import ManiSkill

        self._view = Actor.merge([actors[name] for name in self.names], name="robolab_ms_eval_view")
        if not scene.gpu_sim_enabled:  # one environment: read the PhysX bodies directly, the fastest way on CPU
            import sapien

            self._bodies = [
                actors[name]._objs[0].find_component_by_type(sapien.physx.PhysxRigidBodyComponent)
                for name in self.names
            ]
            self._free_bodies = [body for body in self._bodies if not getattr(body, "kinematic", True)]
            self._body_names = {body: name for body, name in zip(self._bodies, self.names)}
            self._finger_bodies = {
                body: finger for finger, link in zip(self._fingers, finger_links) for body in link._objs
            }
            self._body_names.update(self._finger_bodies)
            self._robot_bodies = {body for link in robot_links or finger_links for body in link._objs}
        bounds = np.stack([entries[name].bounds for name in self.names])  # (N, 2, 3)
        self._local_centres = torch.as_tensor(bounds.mean(axis=1), dtype=torch.float32, device=device)
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
    def all_poses(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Positions (E, N, 3) and rotation matrices (E, N, 3, 3) of every tracked body, in `self.names` order."""

        def read():
            if self.scene.gpu_sim_enabled:
                raw = self._view.pose.raw_pose.reshape(len(self.names), self.num_envs, 7).transpose(0, 1)
            else:
                poses = [body.entity_pose for body in self._bodies]
                raw = np.concatenate([[pose.p for pose in poses], [pose.q for pose in poses]], axis=1)
                raw = torch.as_tensor(raw[None], dtype=torch.float32, device=self.device)
            return raw[..., :3], quaternion_to_matrix(raw[..., 3:])

        return self.cached("poses", read)

    def all_up_axes(self) -> torch.Tensor:
        """Every tracked body's own z axis in the world: (E, N, 3)."""
        return self.all_poses()[1][..., :, 2]

    def all_centres(self) -> torch.Tensor:
        """World centres of every tracked body's bounding box: (E, N, 3)."""

        def compute():
            positions, rotations = self.all_poses()
            return (rotations * self._local_centres[None, :, None, :]).sum(-1) + positions

        return self.cached("centres", compute)

    def position(self, name: str) -> torch.Tensor:
        """World position of the object's frame origin: (E, 3)."""
        return self.all_poses()[0][:, self.index[name]]

    def rotation(self, name: str) -> torch.Tensor:
        """World rotation matrix of the object: (E, 3, 3)."""
        return self.all_poses()[1][:, self.index[name]]

    def up_axis(self, name: str) -> torch.Tensor:
        """The object's own z axis in the world: (E, 3)."""
        return self.rotation(name)[:, :, 2]

    def centre(self, name: str) -> torch.Tensor:
        """World position of the centre of the object's bounding box: (E, 3)."""
        return self.all_centres()[:, self.index[name]]

    def corners(self, name: str) -> torch.Tensor:
        """World positions of the 8 corners of the object's bounding box: (E, 8, 3)."""
        return self.cached(("corners", name), lambda: self.to_world(name, self._local_corners(name)))

    def to_world(self, name: str, local: torch.Tensor) -> torch.Tensor:
        """Object-frame points (P, 3) to world points (E, P, 3)."""
        return (self.rotation(name)[:, None] * local[None, :, None, :]).sum(-1) + self.position(name)[:, None, :]

    def in_frame(self, points: torch.Tensor, name: str) -> torch.Tensor:
        """World points (E, P, 3) to the frame of object `name`."""
        return (self.rotation(name)[:, None] * (points - self.position(name)[:, None, :])[..., None]).sum(-2)

    def top_z(self, name: str) -> torch.Tensor:
        """Height of the highest bounding-box corner: (E,)."""
        return self.corners(name)[:, :, 2].amax(dim=1)

    def footprint(self, name: str) -> tuple[torch.Tensor, torch.Tensor]:
        """World x-y bounds of the object's bounding box: (E, 2) low, (E, 2) high."""
        xy = self.corners(name)[:, :, :2]
        return xy.amin(dim=1), xy.amax(dim=1)

    def linear_speed(self, name: str) -> torch.Tensor:
        return self.cached(("speed", name), lambda: torch.linalg.norm(self.actors[name].linear_velocity, dim=-1))

    # ------------------------------------------------------------------------------------------------ geometry
    def _local_corners(self, name: str) -> torch.Tensor:
        low, high = self.entries[name].bounds
        return self._static(
            ("corners", name),
            lambda: np.array(
                [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
            ),
        )

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
            return self.cached(
                ("gpu_force", a, b), lambda: self.scene.get_pairwise_contact_forces(self._body(a), self._body(b))
            )
        key = (a, b) if a <= b else (b, a)
        if key not in self._wanted_pairs and not (a in self._fingers or b in self._fingers):
            self._wanted_pairs.add(key)
            self._step_cache.pop("cpu_forces", None)  # first time this pair is asked for: read it this step too
        forces = self.cached("cpu_forces", self._cpu_forces)
        force = forces.get((a, b)) if a <= b else -forces.get((b, a), np.zeros(3))
        return torch.as_tensor(np.zeros(3) if force is None else force, dtype=torch.float32, device=self.device)[None]

    def contact_force(self, a: str, b: str) -> torch.Tensor:
        """Magnitude of the contact force between `a` and `b`: (E,). With `gripper`, the fingers' forces add up
        (two fingers squeezing push in opposite directions: their net force says nothing about contact)."""
        if GRIPPER in (a, b):
            other = b if a == GRIPPER else a
            return sum(torch.linalg.norm(self.force_on(finger, other), dim=-1) for finger in self._fingers)
        return torch.linalg.norm(self.force_on(a, b), dim=-1)

    def gripper_forces(self, names: list[str]) -> torch.Tensor:
        """Contact force magnitude between the fingers and each of `names`, summed over fingers: (E, len(names))."""
        if self.scene.gpu_sim_enabled:
            return torch.stack([self.contact_force(name, GRIPPER) for name in names], dim=1)

        def compute():
            column = {name: i for i, name in enumerate(names)}
            values = np.zeros((1, len(names)))
            for (a, b), force in self.cached("cpu_forces", self._cpu_forces).items():
                if a in self._fingers and b in column:
                    values[0, column[b]] += np.linalg.norm(force)
                elif b in self._fingers and a in column:
                    values[0, column[a]] += np.linalg.norm(force)
            return torch.as_tensor(values, dtype=torch.float32, device=self.device)

        return self.cached(("gripper_forces", tuple(names)), compute)

    def non_robot_forces(self, names: list[str]) -> torch.Tensor:
        """Contact force magnitude on each of `names` from everything but the robot (other objects, the table,
        fixtures, the floor), summed over those bodies: (E, len(names)). An object the robot holds up touches
        nothing else. The GPU simulator reports forces between tracked bodies only (objects and the table)."""
        if self.scene.gpu_sim_enabled:
            return torch.stack(
                [sum(self.contact_force(name, other) for other in self.names if other != name) for name in names],
                dim=1,
            )

        def compute():
            column = {name: i for i, name in enumerate(names)}
            impulses: dict[tuple[int, Any], np.ndarray] = {}
            for contact in self.scene.px.get_contacts():
                first, second = contact.bodies
                for mine, other in ((first, second), (second, first)):
                    index = column.get(self._body_names.get(mine))
                    if index is None or other in self._robot_bodies:
                        continue
                    total = sum((point.impulse for point in contact.points), np.zeros(3))
                    key = (index, other)
                    impulses[key] = impulses.get(key, 0.0) + (total if mine is first else -total)
            values = np.zeros((1, len(names)))
            for (index, _), impulse in impulses.items():
                values[0, index] += np.linalg.norm(impulse) / self.scene.px.timestep
            return torch.as_tensor(values, dtype=torch.float32, device=self.device)

        return self.cached(("non_robot_forces", tuple(names)), compute)

    def _body(self, name: str):
        if name in self._fingers:
            return self.finger_links[self._fingers.index(name)]
        return self.actors[name]

    def finger_contacts_if_at_rest(self) -> tuple | None:
        """On the CPU simulator, when PhysX left every tracked object asleep this step: the fingers' contacts as
        comparable values ((pair, force), ...); otherwise (or on the GPU simulator) None. Two steps with equal
        values see the same object poses and contacts, so every predicate gives the same answer."""
        if self.scene.gpu_sim_enabled or not all(body.is_sleeping for body in self._free_bodies):
            return None
        contacts = []
        for contact in self.scene.px.get_contacts():
            first, second = contact.bodies
            if first in self._finger_bodies or second in self._finger_bodies:
                names = (self._body_names.get(first), self._body_names.get(second))
                contacts.append((names, tuple(tuple(point.impulse) for point in contact.points)))
        return tuple(sorted(contacts, key=str))

    def _cpu_forces(self) -> dict[tuple[str, str], np.ndarray]:
        """Force per pair of named bodies (key sorted; value = force on the first), from one pass over contacts.
        Only pairs with a finger and pairs asked for before are summed: the rest would cost time for nothing."""
        # summed in Python floats: the same double-precision sums as numpy's, without its cost per call
        impulses: dict[tuple[str, str], list[float]] = {}
        names, fingers, wanted = self._body_names, self._fingers, self._wanted_pairs
        for contact in self.scene.px.get_contacts():
            bodies = contact.bodies
            a = names.get(bodies[0])
            if a is None:
                continue
            b = names.get(bodies[1])
            if b is None or a == b:
                continue
            if a not in fingers and b not in fingers and ((a, b) if a <= b else (b, a)) not in wanted:
                continue
            x = y = z = 0.0
            for point in contact.points:
                dx, dy, dz = point.impulse.tolist()  # the impulse on bodies[0]
                x, y, z = x + dx, y + dy, z + dz
            key, sign = ((a, b), 1.0) if a <= b else ((b, a), -1.0)
            summed = impulses.setdefault(key, [0.0, 0.0, 0.0])
            summed[0], summed[1], summed[2] = summed[0] + sign * x, summed[1] + sign * y, summed[2] + sign * z
        timestep = self.scene.px.timestep
        return {key: np.array(value) / timestep for key, value in impulses.items()}


def _quaternion_products_to_matrix() -> torch.Tensor:
    """C with R = (q q^T) . C for a unit quaternion q = (w, x, y, z): shape (16, 9)."""
    w, x, y, z = range(4)
    terms = {  # entry of R -> [(coefficient, a, b)] for products q_a q_b
        (0, 0): [(1, w, w), (1, x, x), (-1, y, y), (-1, z, z)],
        (0, 1): [(2, x, y), (-2, w, z)],
        (0, 2): [(2, x, z), (2, w, y)],
        (1, 0): [(2, x, y), (2, w, z)],
        (1, 1): [(1, w, w), (-1, x, x), (1, y, y), (-1, z, z)],
        (1, 2): [(2, y, z), (-2, w, x)],
        (2, 0): [(2, x, z), (-2, w, y)],
        (2, 1): [(2, y, z), (2, w, x)],
        (2, 2): [(1, w, w), (-1, x, x), (-1, y, y), (1, z, z)],
    }
    table = torch.zeros(4, 4, 3, 3)
    for (i, j), entries in terms.items():
        for coefficient, a, b in entries:
            if a == b:
                table[a, b, i, j] += coefficient
            else:  # q_a q_b appears twice in the outer product
                table[a, b, i, j] += coefficient / 2
                table[b, a, i, j] += coefficient / 2
    return table.reshape(16, 9)


_QUATERNION_TABLE = _quaternion_products_to_matrix()


def quaternion_to_matrix(quaternions: torch.Tensor) -> torch.Tensor:
    """Rotation matrices (..., 3, 3) from unit quaternions (..., 4) in (w, x, y, z) order, in a few tensor ops."""
    outer = (quaternions[..., :, None] * quaternions[..., None, :]).reshape(*quaternions.shape[:-1], 16)
    products = (outer[..., None] * _QUATERNION_TABLE.to(quaternions.device)).sum(-2)
    return products.reshape(*quaternions.shape[:-1], 3, 3)
