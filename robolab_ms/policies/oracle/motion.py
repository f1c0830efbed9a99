"""The oracle's motion planner: inverse kinematics and collision-checked joint paths for the arm, queued as the
8-D DROID actions a learned policy sends (7 absolute joint targets and the gripper, 0 open, 1 closed, at the
control rate).

Moves are straight lines of the TCP through inverse-kinematics waypoints a centimetre apart where they can be
(`plan_straight`), mplib's screw motion at the edge of the workspace, and a straight line in joint space or
RRT-Connect to an inverse-kinematics goal otherwise (`move`). The fixtures (shelves) are boxes in the planner's
world, and the planner's model carries the real gripper's solids (`gripper.HAND_SOLIDS`, `planning_model`) in
place of ManiSkill's Panda hand, so its sampled paths keep them out of the fixtures; the straight moves check the
same solids with a margin (`gripper.hand_clear`). On the way to a grasp the hand passes over what stands near its
way (`reach_over`), and beside a fixture it comes to an arm posture from which the straight descent is free
(`reach_over_clear`).
"""

from __future__ import annotations

import functools
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robolab_ms.agents.droid_model import ARM_JOINTS, FLANGE_LINK, panda_model
from robolab_ms.policies.oracle.clearance import (
    APPROACH_HEIGHT,
    TRAVEL_CLEARANCE,
    TRAVEL_RADIUS,
    pass_height,
    sag_height,
)
from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.geometry import boxes_overlap, matrix_to_quaternion, quat_to_matrix
from robolab_ms.policies.oracle.gripper import FINGERTIP_BELOW_TCP, hand_clear
from robolab_ms.policies.oracle.planning_model import planning_urdf
from robolab_ms.policies.oracle.reach import ArmReach
from robolab_ms.policies.oracle.world import fixture_boxes, world_points

if TYPE_CHECKING:
    import sapien

    from robolab_ms.envs.robolab_env import RoboLabEnv

GRIPPER_STEPS = 8  # control steps to close or open the gripper (about half a second)
SETTLE_STEPS = 3  # control steps held at the end of every move, for the PD controller to catch up
IK_STARTS = 20  # starts of inverse kinematics: the current joints, then random ones (mplib's count)
IK_RETRIES = 200  # random starts for inverse kinematics when IK_STARTS found no solution
IK_TOLERANCE = 1e-3  # largest error of a solution: metres plus the quaternion difference (mplib's threshold)
DISTINCT_POSTURE = 0.1  # rad (norm of the joint differences) between two postures inverse kinematics returns
PLANNING_JOINT_SPEED = 1.2  # rad/s, well under the Panda's limits: smooth moves the PD controller can follow
PLANNING_JOINT_ACCELERATION = 1.5  # rad/s^2
JOINT_PATH_RESOLUTION = 0.05  # rad between the configurations checked for self-collision along a joint path
STRAIGHT_STEP = 0.01  # m between the waypoints of a straight move, each solved by inverse kinematics ...
STRAIGHT_TURN = 0.05  # ... or rad of turn between them
MAX_JOINT_JUMP = 0.25  # rad a joint may change between two waypoints of a straight move (more: a flip, not a line)
MAX_SCREW_TRAVEL = 12.0  # rad the joints may travel in all along mplib's screw motion (more: it spins the arm round
# near a singularity, a move longer than an episode)
MAX_SCREW_SECONDS = 20.0  # s one screw motion may last (more: it crawls in tiny steps near a singularity, 30 to 40 s
# for a 4-cm lift, where inverse kinematics and a joint path take a second or two)
HELD_FIXTURE_MARGIN = 0.015  # m kept between a carried object and a fixture (it swings a little in the fingers)
SAMPLED_PLANNING_TIME = 2.0  # s RRT-Connect may take where no straight line in joint space is free
OPEN_FINGER_QPOS = 0.04  # the planning model's finger joints, kept open
PLANNER_HAND_LINKS = ("panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_hand_tcp")  # the planner's hand:
# its hits on a fixture are left to `gripper.hand_clear`, which checks the same solids with a margin
POSTURE_STARTS = 200  # random starts of inverse kinematics when looking for a posture with a clear descent
NEUTRAL_POSTURE = (0.0, np.pi / 8, 0.0, -5 * np.pi / 8, 0.0, 3 * np.pi / 4, np.pi / 4)  # the Panda's rest joints
FIXTURE_MARGIN = 0.02  # m the fixtures grow by while a posture and the way down from it are chosen (the arm lags
# its targets by a centimetre or two on a fast descent)
LOWER_STEP = 0.05  # m between the lower heights over the grasp tried where no posture at the planned one has one

Plan = dict[str, Any]  # mplib's result: "status", and "position" (rows of 7 arm joints) on success
Serves = Callable[[np.ndarray], bool]  # whether a posture found by inverse kinematics serves the caller


def any_posture(posture: np.ndarray) -> bool:
    """Serves every posture: an inverse-kinematics search that stops at the first one found."""
    return True


def seed_planner(seed: int) -> None:
    """Seed the planner's two random sources from the episode seed, so that the oracle's plans depend on it alone:
    the C library's generator (the random starts of mplib's inverse kinematics) and OMPL's (its sampled joint
    paths)."""
    import ctypes

    ctypes.CDLL(None).srand(ctypes.c_uint(seed & 0xFFFFFFFF))
    ompl_set_seed()(seed % 0xFFFFFFFF + 1)  # OMPL ignores a seed of 0


@functools.cache
def ompl_set_seed():
    """`ompl::RNG::setSeed` of the OMPL library that mplib loads; mplib's bindings leave it out. Each call restarts
    the seeds OMPL hands its samplers, so a sampled path depends only on the last seed and the problem."""
    import ctypes

    import mplib

    bundled = sorted((Path(mplib.__file__).parent.parent / "mplib.libs").glob("libompl*.so*"))
    if not bundled:
        raise OracleFailure("no OMPL library beside mplib: the oracle needs the mplib wheel pinned in pyproject.toml")
    set_seed = ctypes.CDLL(str(bundled[0]))._ZN4ompl3RNG7setSeedEm  # ompl::RNG::setSeed(unsigned long)
    set_seed.argtypes, set_seed.restype = [ctypes.c_ulong], None
    return set_seed


def make_planner(env: RoboLabEnv):
    """An mplib planner for the robot's arm. Every supported robot has a Panda arm, so the planner uses ManiSkill's
    Panda model (with its collision pairs) and moves the flange, panda_link8; the hand on the flange differs per
    robot: its collision geometry is the gripper's solids at the robot's TCP (`planning_model`), and the
    flange-to-TCP transform is read from the robot (see `MotionPlanner.bind`)."""
    import mplib

    if tuple(env.robot.arm_joints) != ARM_JOINTS:
        raise OracleFailure(f"the oracle plans for Panda arms (droid, panda); robot '{env.robot_uids}' has another arm")
    _, srdf = panda_model()
    tcp = tcp_in_flange(env)
    return mplib.Planner(
        urdf=str(planning_urdf(np.concatenate([tcp.p, tcp.q]))),
        srdf=str(srdf),
        move_group=FLANGE_LINK,
        joint_vel_limits=np.full(7, PLANNING_JOINT_SPEED),
        joint_acc_limits=np.full(7, PLANNING_JOINT_ACCELERATION),
    )


def tcp_in_flange(env: RoboLabEnv) -> sapien.Pose:
    """The robot's TCP pose in its flange frame, a sapien.Pose (fixed: the hand is rigid on the flange)."""
    flange = env.agent.robot.links_map[FLANGE_LINK].pose
    return (flange.inv() * env.tcp_pose()).sp


class MotionPlanner:
    """Plans the arm's moves for one robot and queues them as actions (`actions`), with the gripper command of
    the moment (`gripper`). Postures are planning-model joint vectors: the 7 arm joints, then the 2 fingers."""

    time_each_move = False  # True: a chain's moves are timed as they are found, not once the whole chain is found
    # (the baseline of benchmarks/validation_cost.py --oracle-baseline); the actions are the same either way

    def __init__(self, env: RoboLabEnv) -> None:
        self.planner = make_planner(env)
        self.reach = ArmReach.of(self.planner, FLANGE_LINK)
        self.robot = env.robot_uids
        self.env = env
        self.actions: deque[np.ndarray] = deque()
        self.gripper = 0.0
        self.fixture_names: list[str] = []
        self._fixture_box_cache: tuple | None = None
        self.tcp_in_flange = None
        self.held: tuple[np.ndarray, np.ndarray] | None = None  # the carried object's box in the TCP frame (middle,
        # half extents), while `carrying`

    def bind(self, env: RoboLabEnv) -> None:
        """Plan for `env` (the unwrapped RoboLabEnv): read the fixed transform from the flange to the TCP."""
        self.env = env
        self.tcp_in_flange = tcp_in_flange(env)

    # -------------------------------------------------------------------------------------------- the queue
    def mark(self) -> tuple[int, float]:
        """A mark of the queue and the gripper command as they are now, for `rewind`."""
        return len(self.actions), self.gripper

    def rewind(self, mark: tuple[int, float]) -> None:
        """Drop the actions queued since `mark` (a plan given up half-way), and the gripper command with them."""
        length, self.gripper = mark
        while len(self.actions) > length:
            self.actions.pop()

    def action(self, qpos: np.ndarray, gripper: float) -> np.ndarray:
        """The env's 8-D action from a planning-model joint vector: 7 arm joint targets, then the gripper."""
        return np.concatenate([qpos[:7], [gripper]]).astype(np.float32)

    def hold(self, qpos: np.ndarray, gripper: float, steps: int) -> None:
        """Queue `steps` actions holding posture `qpos` with the gripper at `gripper` (which stays commanded)."""
        self.gripper = gripper
        for _ in range(steps):
            self.actions.append(self.action(qpos, gripper))

    def queue(self, qpos: np.ndarray, path) -> np.ndarray:
        """Queue a joint path (rows of 7 arm joints) from posture `qpos`, then hold its end a moment; returns the
        final posture."""
        final = qpos.copy()
        for joints in path:
            final[:7] = joints
            self.actions.append(self.action(final, self.gripper))
        self.hold(final, self.gripper, SETTLE_STEPS)
        return final

    # -------------------------------------------------------------------------------------------- the arm
    @property
    def time_step(self) -> float:
        return 1.0 / self.env.control_freq

    def current_qpos(self) -> np.ndarray:
        """The planning model's joints (the arm's 7, then 2 fingers, kept open) from the robot's state."""
        arm = self.env.arm_qpos()[0].cpu().numpy().astype(np.float64)
        return np.concatenate([arm, [OPEN_FINGER_QPOS, OPEN_FINGER_QPOS]])

    def flange_target(self, tcp_pose: np.ndarray) -> np.ndarray:
        """The flange pose [x, y, z, qw, qx, qy, qz] that puts the TCP at `tcp_pose`."""
        import sapien

        flange = sapien.Pose(p=tcp_pose[:3], q=tcp_pose[3:]) * self.tcp_in_flange.inv()
        return np.concatenate([flange.p, flange.q])

    def tcp_at(self, qpos: np.ndarray) -> np.ndarray:
        """The TCP pose [x, y, z, qw, qx, qy, qz] at posture `qpos` (forward kinematics)."""
        import sapien

        model = self.planner.pinocchio_model
        model.compute_forward_kinematics(qpos)
        flange = np.asarray(model.get_link_pose(self.planner.link_name_2_idx[FLANGE_LINK]))
        tcp = sapien.Pose(p=flange[:3], q=flange[3:]) * self.tcp_in_flange
        return np.concatenate([tcp.p, tcp.q])

    def ik(
        self, pose: np.ndarray, qpos: np.ndarray, starts: int | None = None, serves: Serves | None = None
    ) -> tuple[str, list[np.ndarray]]:
        """Inverse kinematics for TCP `pose` (`flange_ik`)."""
        return self.flange_ik(self.flange_target(pose), qpos, starts or IK_STARTS, serves)

    def flange_ik(
        self, flange_pose: np.ndarray, qpos: np.ndarray, starts: int = IK_STARTS, serves: Serves | None = None
    ) -> tuple[str, list[np.ndarray]]:
        """Inverse kinematics for flange pose `flange_pose`: (status, postures), the distinct postures free of
        collisions that put the flange there, solved from `qpos` and then from `starts` - 1 random joints, in the
        order found (the answer of mplib's `Planner.IK`, whose random starts the C library's generator draws).

        With `serves`, the search stops at the first posture that serves: status "Success" and that posture alone;
        where none serves, a status that says so and every posture found. The random starts not tried are still
        drawn, so that what the planner does next does not depend on where the search stopped. A pose out of the
        arm's reach (`reach.ArmReach`) is not searched; its starts are drawn all the same."""
        planner = self.planner
        model, link = planner.pinocchio_model, planner.link_name_2_idx[FLANGE_LINK]
        group = planner.move_group_joint_indices
        planner.robot.set_qpos(qpos, True)
        if self.reach.out_of_reach(flange_pose):  # no start would converge: skip the search, draw its starts
            for _ in range(starts):
                model.get_random_configuration()
            return f"IK Failed! The pose is {self.reach.beyond(flange_pose):f} m beyond the arm's reach.", []
        found: list[np.ndarray] = []
        nearest, served = np.inf, None
        start = np.array(qpos, dtype=np.float64)
        for _ in range(starts):
            if served is None:
                posture = np.asarray(model.compute_IK_CLIK(link, flange_pose, start)[0])
                valid = planner.wrap_joint_limit(posture)
                if valid:
                    planner.planning_world.set_qpos_all(posture[group])
                    valid = not planner.planning_world.collide_full()
                if valid:
                    model.compute_forward_kinematics(posture)
                    reached = np.asarray(model.get_link_pose(link))
                    error = planner.distance_6D(flange_pose[:3], flange_pose[3:], reached[:3], reached[3:])
                    nearest = min(nearest, error)
                    distinct = all(np.linalg.norm(other[group] - posture[group]) >= DISTINCT_POSTURE for other in found)
                    if error < IK_TOLERANCE and distinct:
                        found.append(posture)
                        if serves is not None and serves(posture):
                            served = posture
            start = model.get_random_configuration()
        if served is not None:
            return "Success", [served]
        if found:
            return ("Success" if serves is None else "no posture found serves"), found
        if np.isfinite(nearest):
            return f"IK Failed! Distance {nearest:f} is greater than threshold {IK_TOLERANCE:f}.", found
        return "IK Failed! Cannot find valid solution.", found

    # -------------------------------------------------------------------------------------------- collisions
    def sync_fixtures(self) -> None:
        """Give the planner the episode's fixtures (shelves) as boxes, so that inverse kinematics and the planned
        moves keep the arm out of them (the other objects are left out: the hand reaches in among them)."""
        import mplib.pymp as mp

        fcl = mp.collision_detection.fcl
        for name in self.fixture_names:
            self.planner.remove_normal_object(name)
        self.fixture_names = []
        if self.env.scene.gpu_sim_enabled:
            return
        for index, (rotation, centre, half) in enumerate(fixture_boxes(self.env)):
            name = f"fixture_{index}"
            box = fcl.CollisionObject(fcl.Box(2 * half), centre, matrix_to_quaternion(rotation))
            self.planner.set_normal_object(name, box)
            self.fixture_names.append(name)

    @contextmanager
    def inflated_fixtures(self, margin: float) -> Iterator[None]:
        """The planner's fixture boxes grown by `margin` on every side for the duration, the exact ones after."""
        import mplib.pymp as mp

        fcl = mp.collision_detection.fcl
        boxes = fixture_boxes(self.env) if self.fixture_names else []

        def install(grow: float) -> None:
            for name, (rotation, centre, half) in zip(self.fixture_names, boxes):
                shape = fcl.CollisionObject(fcl.Box(2 * (half + grow)), centre, matrix_to_quaternion(rotation))
                self.planner.set_normal_object(name, shape)

        install(margin)
        try:
            yield
        finally:
            install(0.0)

    @contextmanager
    def carrying(self, points: np.ndarray) -> Iterator[None]:
        """For the duration, the moves planned keep the held object's box (the bounding box of `points`, (N, 3) in
        the TCP frame) HELD_FIXTURE_MARGIN clear of the fixtures, as well as the arm."""
        low, high = points.min(axis=0), points.max(axis=0)
        self.held = ((low + high) / 2, (high - low) / 2)
        try:
            yield
        finally:
            self.held = None

    def collides(self, qpos: np.ndarray) -> bool:
        """Whether the arm at planning-model joints `qpos` collides with itself or a fixture."""
        if self.planner.check_for_self_collision(qpos=qpos):
            return True
        return bool(self.fixture_names) and self.arm_hits_fixture(qpos)

    def arm_hits_fixture(self, qpos: np.ndarray) -> bool:
        """Whether the arm at planning-model joints `qpos` hits a fixture: its links from the flange back as the
        planner models them, the hand as the real gripper's solids at the TCP (`gripper.hand_clear`), and the
        object it carries (`carrying`)."""
        if any(hit.link_name1 not in PLANNER_HAND_LINKS for hit in self.planner.check_for_env_collision(qpos=qpos)):
            return True
        boxes = self._fixture_box_cache
        if boxes is None or boxes[0] is not self.env or boxes[1] != self.fixture_names:
            self._fixture_box_cache = boxes = (self.env, list(self.fixture_names), fixture_boxes(self.env))
        tcp = self.tcp_at(qpos)
        if self.held is not None:
            rotation, (middle, half) = quat_to_matrix(tcp[3:]), self.held
            held = (rotation, tcp[:3] + rotation @ middle, half)
            if any(boxes_overlap(held, box, HELD_FIXTURE_MARGIN) for box in boxes[2]):
                return True
        return not hand_clear(tcp, boxes[2])

    # -------------------------------------------------------------------------------------------- paths
    def plan_straight(self, flange_pose: np.ndarray, qpos: np.ndarray) -> Plan:
        """A timed joint path that moves the flange along a straight line (and the shortest turn) to `flange_pose`
        (`straight_waypoints`); fails on a joint limit, a jump or a collision."""
        waypoints = self.straight_waypoints(flange_pose, qpos)
        if waypoints is None:
            return {"status": "straight move failed"}
        return {"status": "Success", "position": self.timed(waypoints)}

    def screw(self, flange_pose: np.ndarray, qpos: np.ndarray) -> Plan:
        """mplib's screw motion of the flange to `flange_pose` (near the edge of the workspace, where it may stop a
        centimetre short), refused where its joints travel more than MAX_SCREW_TRAVEL or it lasts longer than
        MAX_SCREW_SECONDS."""
        result = self.planner.plan_screw(flange_pose, qpos, time_step=self.time_step)
        if result["status"] == "Success" and len(result["position"]) > 1:
            travel = float(np.abs(np.diff(np.asarray(result["position"]), axis=0)).max(axis=1).sum())
            if travel > MAX_SCREW_TRAVEL:
                return {"status": f"the screw motion spins the arm round ({travel:.0f} rad of joint travel)"}
            seconds = len(result["position"]) * self.time_step
            if seconds > MAX_SCREW_SECONDS:
                return {"status": f"the screw motion crawls ({seconds:.0f} s for one move)"}
        return result

    def straight_waypoints(self, flange_pose: np.ndarray, qpos: np.ndarray) -> np.ndarray | None:
        """The joint waypoints (N, 7) of a straight move of the flange (and the shortest turn) to `flange_pose`:
        inverse kinematics solved from the previous waypoint every STRAIGHT_STEP metres (or STRAIGHT_TURN radians),
        so the path ends on the pose to within a millimetre; None on a joint limit, a jump or a collision."""
        from scipy.spatial.transform import Rotation, Slerp

        planner = self.planner
        model, flange = planner.pinocchio_model, planner.link_name_2_idx[FLANGE_LINK]
        model.compute_forward_kinematics(qpos)
        start = np.asarray(model.get_link_pose(flange))
        turns = Rotation.from_quat([np.roll(start[3:], -1), np.roll(flange_pose[3:], -1)])  # (x, y, z, w) order
        angle = (turns[0].inv() * turns[1]).magnitude()
        distance = float(np.linalg.norm(flange_pose[:3] - start[:3]))
        count = max(1, int(np.ceil(max(distance / STRAIGHT_STEP, angle / STRAIGHT_TURN))))
        fractions = np.arange(1, count + 1) / count
        orientations = np.roll(Slerp([0.0, 1.0], turns)(fractions).as_quat(), 1, axis=1)  # (w, x, y, z) order
        lower, upper = np.asarray(planner.joint_limits)[:7].T
        current, path = qpos.copy(), [qpos[:7].copy()]
        for fraction, orientation in zip(fractions, orientations, strict=True):
            waypoint = np.concatenate([start[:3] + fraction * (flange_pose[:3] - start[:3]), orientation])
            solution, converged, _ = model.compute_IK_CLIK(flange, waypoint, current)
            solution = np.asarray(solution)
            if (
                not converged
                or np.any(solution[:7] < lower - 1e-3)
                or np.any(solution[:7] > upper + 1e-3)
                or np.abs(solution[:7] - current[:7]).max() > MAX_JOINT_JUMP
                or self.collides(solution)
            ):
                return None
            current = solution
            path.append(current[:7].copy())
        return np.asarray(path)

    def timed(self, waypoints: np.ndarray) -> np.ndarray:
        """The joint positions at every control step along `waypoints` (N, 7), at the arm's speed and
        acceleration limits (time-optimal parameterisation)."""
        _, position, *_ = self.planner.TOPP(waypoints, self.time_step)
        return position

    def free_joint_path(self, qpos: np.ndarray, goal: np.ndarray) -> np.ndarray | None:
        """The postures every JOINT_PATH_RESOLUTION along the straight line in joint space from `qpos` to `goal`,
        untimed, or None where one of them collides (`free_joint_line` times it and lets the arm leave a collision it
        starts in)."""
        count = int(np.ceil(np.max(np.abs(goal[:7] - qpos[:7])) / JOINT_PATH_RESOLUTION)) + 1
        path = np.linspace(qpos, goal, max(count, 2))
        if any(self.collides(point) for point in path):
            return None
        return path

    def plan_to_joints(self, goals: list[np.ndarray], qpos: np.ndarray) -> Plan:
        """A timed joint path to the first goal reachable by a straight line in joint space free of collisions; a
        sampling planner (seeded by `seed_planner`) only when no straight line is free."""
        for goal in goals:
            path = self.free_joint_path(qpos, goal)
            if path is not None:
                return self.timed_joint_path(path)
        return self.sampled_path(goals, qpos)

    def timed_joint_path(self, path: np.ndarray) -> Plan:
        """The plan along the postures `path` (`free_joint_path`), timed; its last posture alone where the path
        does not move the arm."""
        if np.array_equal(path[0, :7], path[-1, :7]):
            return {"status": "Success", "position": path[-1:, :7]}
        _, position, *_ = self.planner.TOPP(path[:, :7], self.time_step)
        return {"status": "Success", "position": position}

    def sampled_path(self, goals: list[np.ndarray], qpos: np.ndarray) -> Plan:
        """A timed joint path to one of `goals` found by a sampling planner (RRT-Connect, seeded by
        `seed_planner`), free of collisions with the held object too."""
        planner = self.planner
        result = planner.plan_qpos_to_qpos(goals, qpos, time_step=self.time_step, planning_time=SAMPLED_PLANNING_TIME)
        if result["status"] == "Success" and self.held is not None:  # the sampled planner knows nothing of it
            posture = qpos.copy()
            for joints in result["position"]:
                posture[:7] = joints
                if self.collides(posture):
                    return {"status": "the sampled path takes the held object into a fixture"}
        return result

    def straight_chain(self, qpos: np.ndarray, poses: list[np.ndarray]) -> list[np.ndarray] | None:
        """Timed joint paths of consecutive straight moves through TCP `poses` from `qpos`, or None if one fails.
        The moves are timed only once all of them are found (most chains tried are given up part of the way)."""
        paths, timed, current = [], [], qpos.copy()
        for pose in poses:
            waypoints = self.straight_waypoints(self.flange_target(pose), current)
            if waypoints is not None:
                paths.append(self.timed(waypoints) if self.time_each_move else waypoints)
                timed.append(self.time_each_move)
                current[:7] = waypoints[-1]
                continue
            # at the edge of the workspace: within a centimetre of the pose
            result = self.screw(self.flange_target(pose), current)
            if result["status"] != "Success":
                return None
            position = np.asarray(result["position"])
            if len(position) == 0:  # the screw motion found the hand already there: a path that stays put
                position = current[None, :7].copy()
            paths.append(position)
            timed.append(True)
            current[:7] = position[-1]
        return [path if done else self.timed(path) for path, done in zip(paths, timed)]

    def free_joint_line(self, qpos: np.ndarray, goal: np.ndarray) -> np.ndarray | None:
        """A timed joint path along the straight line in joint space from `qpos` to `goal`, free of collisions once
        the arm has left a collision it starts in (the planner's hand model is wider than the gripper and may touch
        a shelf at the start); None where it is not free."""
        count = int(np.ceil(np.max(np.abs(goal[:7] - qpos[:7])) / JOINT_PATH_RESOLUTION)) + 1
        path = np.linspace(qpos, goal, max(count, 2))
        leaving = True
        for point in path[1:]:
            hit = self.collides(point)
            if hit and not leaving:
                return None
            leaving = leaving and hit
        if leaving:
            return None
        _, position, *_ = self.planner.TOPP(path[:, :7], self.time_step)
        return position

    # -------------------------------------------------------------------------------------------- moves
    def move(self, qpos: np.ndarray, pose: np.ndarray, what: str, straight: bool = True) -> np.ndarray:
        """Queue the actions of one move to TCP `pose`, a straight line if `straight` and one can be planned;
        returns the final joints. OracleFailure, saying `what` could not be done, where no move is planned."""
        pose = self.flange_target(pose)
        result = self.plan_straight(pose, qpos) if straight else {"status": "not tried"}
        if straight and result["status"] != "Success":  # at the edge of the workspace: a straight line that may miss
            result = self.screw(pose, qpos)  # the pose by a centimetre, or none
        if result["status"] != "Success":
            line: list[np.ndarray | None] = [None]  # the free joint path to the last posture tried

            def free_line(goal: np.ndarray) -> bool:
                line[0] = self.free_joint_path(qpos, goal)
                return line[0] is not None

            status, goals = self.flange_ik(pose, qpos, serves=free_line)
            if not goals:  # near the edge of the workspace: try harder
                status, goals = self.flange_ik(pose, qpos, IK_RETRIES, serves=free_line)
            if status == "Success":  # the search stopped at the posture with a free line
                result = self.timed_joint_path(line[0])
            else:  # no posture found has a free straight line in joint space
                result = self.sampled_path(goals, qpos) if goals else {"status": status}
        if result["status"] != "Success":
            raise OracleFailure(f"cannot {what}: no motion plan ({result['status']}); the pose may be unreachable")
        return self.queue(qpos, result["position"])

    def move_straight(self, qpos: np.ndarray, pose: np.ndarray, what: str) -> np.ndarray:
        """Queue a straight move of the TCP to `pose` (mplib's screw motion where the straight line fails), never
        a sampled path: for moves that must keep a held object on its line (out of a shelf); returns the final
        joints."""
        paths = self.straight_chain(qpos, [pose])
        if paths is None:
            raise OracleFailure(f"cannot {what}: no straight move")
        return self.queue(qpos, paths[0])

    def can_lower(self, over: np.ndarray, place: np.ndarray, starts: int | None = None) -> bool:
        """Whether the arm reaches TCP pose `over` (by inverse kinematics, from the planner's own random starts or
        `starts` of them) and from there moves straight to `place`."""
        status, postures = self.ik(over, self.current_qpos(), starts, serves=any_posture)
        if status != "Success":
            return False
        start = self.current_qpos()
        start[:7] = postures[0][:7]
        return self.plan_straight(self.flange_target(place), start)["status"] == "Success"

    def move_for_chain(self, qpos: np.ndarray, pose: np.ndarray, chain: list[np.ndarray], what: str) -> np.ndarray:
        """Queue the move from posture `qpos` to TCP pose `pose` (`move`, a sampled path allowed) so that it ends
        in a posture from which the straight moves through the TCP poses `chain` can be planned: where the posture
        it reaches has none, the postures over `pose` found from many random starts are tried (nearest the arm's
        rest posture turned towards `pose` first). Returns the final joints."""
        planned = self.mark()
        end = self.move(qpos, pose, what, straight=False)
        if self.straight_chain(end, chain) is not None:
            return end
        status, goals = self.ik(pose, qpos, POSTURE_STARTS)
        if status != "Success":
            return end
        for goal in sorted(goals, key=lambda joints: _from_neutral(joints, pose)):
            start = qpos.copy()
            start[:7] = goal[:7]
            if self.collides(start) or self.straight_chain(start, chain) is None:
                continue
            result = self.plan_to_joints([start], qpos)
            if result["status"] != "Success":
                continue
            self.rewind(planned)
            return self.queue(qpos, result["position"])
        return end

    # -------------------------------------------------------------------------------------------- reaches
    def reach_over(self, qpos: np.ndarray, above_grasp: np.ndarray, name: str) -> np.ndarray:
        """Queue the move from posture `qpos` to `above_grasp` (over object `name`); where something tall (a
        crate's wall) rises near the straight way there, or the planned joint path itself dips onto something on
        the way (`clearance.sag_height`), the hand first goes over the grasp at a height that passes above
        everything on the way, then straight down. Returns the final joints."""
        what = f"reach above '{name}'"
        start = self.tcp_at(qpos)[:3]
        height = pass_height(self.env, np.asarray(start, dtype=np.float64), above_grasp[:3], name)
        if height is None:
            planned = self.mark()
            end = self.move(qpos, above_grasp, what, straight=False)
            height = self._sagging_height(planned[0], name)
            if height is None:
                return end
            self.rewind(planned)
            height = max(height, float(above_grasp[2]))
        transit = above_grasp.copy()
        transit[2] = height
        qpos = self.move(qpos, transit, what, straight=False)
        return self.move(qpos, above_grasp, f"come down over '{name}'")

    def _sagging_height(self, first_action: int, name: str) -> float | None:
        """`clearance.sag_height` along the TCP path of the actions queued from `first_action` on."""
        actions = list(self.actions)[first_action:]
        if not actions:
            return None
        joints = self.current_qpos()
        way = []
        for action in actions:
            joints[:7] = action[:7]
            way.append(self.tcp_at(joints)[:3])
        return sag_height(self.env, np.asarray(way, dtype=np.float64), name)

    def reach_over_clear(self, qpos: np.ndarray, above: np.ndarray, target: np.ndarray, name: str) -> np.ndarray:
        """Queue the move from posture `qpos` to TCP pose `above` over object `name` (`reach_over`); where fixtures
        are in the scene and the straight move from there down to `target` cannot be planned (beside a shelf the
        forearm of the posture inverse kinematics picks may pass through a board, and a joint-space fallback would
        swing the open fingers through the object), the move goes instead to a posture from which it can
        (`clear_posture`), if there is one; where `above` cannot be reached at all, to such a posture lower down
        (`clear_approach`). Returns the final joints."""
        planned = self.mark()
        try:
            end = self.reach_over(qpos, above, name)
        except OracleFailure as error:  # `above` out of reach (raised high over a tall neighbour): lower, if it clears
            failure, end = error, None
        if end is not None and not self.fixture_names:
            return end
        if end is not None and self.plan_straight(self.flange_target(target), end)["status"] == "Success":
            return end
        with self.inflated_fixtures(FIXTURE_MARGIN):
            path = self.clear_approach(qpos, above, target)
        if path is None:
            if end is None:
                raise failure
            return end
        self.rewind(planned)
        return self.queue(qpos, path)

    def clear_posture(self, qpos: np.ndarray, above: np.ndarray, target: np.ndarray) -> np.ndarray | None:
        """A posture with the TCP at pose `above` from which a straight move to TCP pose `target` is planned free
        of the fixtures, nearest in joint space to the arm's neutral posture turned towards `target` (not to
        `qpos`, which after a place on a high shelf may be a flipped one); None where there is none."""
        status, goals = self.ik(above, qpos, POSTURE_STARTS)
        if status != "Success":
            return None
        goal_flange = self.flange_target(target)
        for goal in sorted(goals, key=lambda joints: _from_neutral(joints, target)):
            start = qpos.copy()
            start[:7] = goal[:7]
            if self.collides(start):
                continue
            if self.plan_straight(goal_flange, start)["status"] == "Success":
                return start
        return None

    def clear_approach(self, qpos: np.ndarray, above: np.ndarray, target: np.ndarray) -> np.ndarray | None:
        """A timed joint path from `qpos` to a posture over `target` from which the straight move down to it is free
        (`clear_posture`): at the height of `above`, else at lower heights from which the fingertips still clear the
        objects around (`clears_below`); None where there is none."""
        goal = self.clear_posture(qpos, above, target)
        if goal is not None:
            result = self.plan_to_joints([goal], qpos)
            if result["status"] == "Success":
                return result["position"]
        for height in np.arange(above[2] - LOWER_STEP, target[2], -LOWER_STEP):  # beside a tall shelf: come in lower
            lowered = above.copy()
            lowered[2] = height
            if not self.clears_below(lowered, target):
                continue
            goal = self.clear_posture(qpos, lowered, target)
            path = self.free_joint_line(qpos, goal) if goal is not None else None
            if path is not None:
                return path
        return None

    def clears_below(self, pose: np.ndarray, target: np.ndarray) -> bool:
        """Whether TCP pose `pose` is at least APPROACH_HEIGHT above `target` and its fingertips TRAVEL_CLEARANCE
        above every object within TRAVEL_RADIUS that rises from below it (the fixtures aside, which the planner keeps
        the arm out of, and what stands on their levels above the hand)."""
        if pose[2] < target[2] + APPROACH_HEIGHT - 1e-6:
            return False
        env = self.env
        env.eval_context.refresh()
        for name in env.objects:
            if env.eval_context.entries[name].is_fixture:
                continue
            points = world_points(env, name)
            if points[:, 2].min() > pose[2]:
                continue
            near = np.linalg.norm(points[:, :2] - pose[:2], axis=1) < TRAVEL_RADIUS
            if float(points[near, 2].max(initial=0.0)) + TRAVEL_CLEARANCE + FINGERTIP_BELOW_TCP > pose[2]:
                return False
        return True


def _from_neutral(joints: np.ndarray, towards: np.ndarray) -> float:
    """How far (rad, the largest joint difference) `joints` lie from the arm's neutral posture with its shoulder
    turned towards TCP position `towards`."""
    neutral = np.array(NEUTRAL_POSTURE)
    neutral[0] = np.arctan2(towards[1], towards[0])
    return float(np.abs(joints[:7] - neutral).max())
