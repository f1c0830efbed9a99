"""The oracle's layers on their own, not whole tasks: the top-down grasp generator and its scorer on a box of known
size (no simulator), and, on the PredicateLab fixture scene (a bin, a plate, a bowl, a mug and three blocks), the
world view, the place samplers, the motion planner's inverse kinematics and paths, and the pick-and-place skill
putting the red block into the bin."""

import numpy as np
import pytest
from helpers import FIXTURES, task_at_reset

from robolab_ms.policies.oracle.clearance import APPROACH_HEIGHT
from robolab_ms.policies.oracle.geometry import down_quaternion, quat_to_matrix, raised
from robolab_ms.policies.oracle.grasps import (
    FINGERTIP_CLEARANCE,
    across_candidates,
    closing_directions,
    grasp_pose,
)
from robolab_ms.policies.oracle.gripper import MAX_GRASP_WIDTH, OPEN_FINGER_GAP, pad_drop
from robolab_ms.policies.oracle.scoring import FINGER_CLASH_TOLERANCE, FINGER_SNAG, hand_clash

BOX = (0.04, 0.06, 0.05)  # m along x, y, z: narrowest along x


def box_points(size=BOX, step: float = 0.005) -> np.ndarray:
    """Points on the surface of a box standing on the table at the origin."""
    axes = [np.arange(-s / 2, s / 2 + 1e-9, step) for s in size[:2]] + [np.arange(0.0, size[2] + 1e-9, step)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    low, high = np.array([-size[0] / 2, -size[1] / 2, 0.0]), np.array([size[0] / 2, size[1] / 2, size[2]])
    on_face = np.any(np.isclose(grid, low) | np.isclose(grid, high), axis=1)
    return grid[on_face]


def candidates(points: np.ndarray, heights=None, failed=()) -> list:
    """The top-down candidates for the object of `points` centred on its footprint (no simulator: the generator
    consults the scene only where a finger clashes beyond the tolerance, which these tests keep below)."""
    middle = (points.max(axis=0) + points.min(axis=0)) / 2
    directions = closing_directions(points)
    bottom = float(points[:, 2].min())
    return list(
        across_candidates(None, "box", points, None, middle, directions, bottom, heights, False, False, list(failed))
    )


def best(found: list):
    return min(found, key=lambda candidate: candidate.score.key)


def test_a_box_is_closed_on_across_its_narrow_side_with_room_in_the_open_fingers():
    points = box_points()
    found = candidates(points)
    assert found and all(candidate.width < MAX_GRASP_WIDTH < OPEN_FINGER_GAP for candidate in found)
    chosen = best(found)
    assert abs(float(chosen.closing @ [1.0, 0.0])) == pytest.approx(1.0)  # across the 4-cm side
    assert chosen.width == pytest.approx(BOX[0], abs=1e-6)
    assert np.allclose(chosen.xy, 0.0, atol=1e-9) and not chosen.score.moved
    assert BOX[2] > chosen.z >= pad_drop(chosen.width) + FINGERTIP_CLEARANCE - 1e-9  # on it, the pads off the table
    rotation = quat_to_matrix(down_quaternion(chosen.closing))
    assert np.allclose(rotation[:, 2], [0.0, 0.0, -1.0]) and np.allclose(rotation[:2, 1], chosen.closing)


def test_the_scorer_ranks_open_fingers_on_a_neighbour_below_a_grasp_that_clears():
    """A low neighbour (3 cm) runs along the box's +x side: fingers closing along x come down on it (a snag the hand
    would push through, but one that pinches the neighbour), so the grasp turned to close along y wins."""
    points = box_points()
    steps = np.arange(-0.2, 0.2 + 1e-9, 0.008)
    cells = np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2)
    tops = np.where((cells[:, 0] > 0.035) & (cells[:, 0] < 0.06), 0.03, -np.inf)
    found = candidates(points, heights=(cells, tops))
    across_x = next(c for c in found if abs(float(c.closing @ [1.0, 0.0])) > 0.999 and not c.score.moved)
    fingers, _ = hand_clash((cells, tops), across_x.xy, across_x.closing, across_x.z)
    assert FINGER_SNAG < fingers < FINGER_CLASH_TOLERANCE and across_x.score.snag
    chosen = best(found)
    assert abs(float(chosen.closing @ [0.0, 1.0])) == pytest.approx(1.0) and not chosen.score.snag
    assert chosen.score.key < across_x.score.key
    assert hand_clash((cells, tops), chosen.xy, chosen.closing, chosen.z)[0] == 0.0


def test_a_grasp_near_one_that_failed_comes_last():
    points = box_points()
    first = best(candidates(points))
    failed = np.concatenate([[*first.xy, first.z], down_quaternion(first.closing)])
    again = best(candidates(points, failed=[failed]))
    assert not again.score.failed_nearby
    assert np.linalg.norm(again.xy - first.xy) > 0.02 or abs(float(again.closing @ first.closing)) < 0.9


# ------------------------------------------------------------------------------------------------ on a scene
@pytest.fixture(scope="module")
def lab():
    from robolab_ms.envs import RoboLabEnv

    env = RoboLabEnv(task=str(FIXTURES / "PredicateLab.yaml"), obs_mode="state_dict", render_backend="cpu")
    env.reset(seed=0)
    yield env
    env.close()


@pytest.fixture
def motion(lab):
    from robolab_ms.policies.oracle.motion import MotionPlanner, seed_planner

    lab.reset(seed=0)
    lab.eval_context.refresh()
    seed_planner(0)
    planner = MotionPlanner(lab)
    planner.bind(lab)
    planner.sync_fixtures()
    return planner


def test_the_world_view_reads_sizes_supports_and_containers(lab):
    from robolab_ms.policies.oracle.world import (
        centre,
        container_below,
        is_container,
        lying_container,
        standing_container,
        world_points,
    )

    lab.reset(seed=0)
    block = world_points(lab, "red")
    assert np.allclose(np.ptp(block, axis=0), np.ptp(block, axis=0).max(), atol=0.002)  # a cube
    assert block[:, 2].min() == pytest.approx(0.0, abs=0.005)  # on the table
    assert is_container(lab, "bin") and standing_container(lab, "bin") and not lying_container(lab, "bin")
    assert not is_container(lab, "red") and container_below(lab, "red") is None
    assert np.allclose(centre(lab, "red")[:2], block[:, :2].mean(axis=0), atol=0.005)


def test_the_place_samplers_find_a_free_spot_in_the_bin_and_left_of_the_plate(motion):
    from robolab_ms.policies.oracle.places import (
        RELEASE_CLEARANCE,
        SIDE_OFFSET,
        SPOT_MARGIN,
        free_place,
        free_spot,
        spot_beside,
    )
    from robolab_ms.policies.oracle.world import centre, object_bottom, world_points

    lab = motion.env
    grasp = grasp_pose(lab, "red")
    held_bottom = grasp[2] - object_bottom(lab, "red")
    place, over = free_place(lab, "red", "bin", grasp, held_bottom, motion.can_lower)
    bin_points, block = world_points(lab, "bin"), world_points(lab, "red") - grasp[:3]
    low, high = bin_points[:, :2].min(axis=0), bin_points[:, :2].max(axis=0)
    released = block + place[:3]  # the block as held, at the release
    assert np.all(released[:, :2] > low) and np.all(released[:, :2] < high)  # over the bin's floor
    assert released[:, 2].min() == pytest.approx(bin_points[:, 2].min() + RELEASE_CLEARANCE, abs=0.02)
    assert over[2] > place[2] and np.allclose(over[:2], place[:2])
    assert motion.can_lower(over, place)

    left = spot_beside(lab, "plate", "left_of")
    assert np.allclose(left, centre(lab, "plate")[:2] + [0.0, SIDE_OFFSET])
    box = free_spot(lab, "red", avoid=["red"], taken=[], near=np.asarray(left))
    for other in ("bin", "plate", "bowl", "mug", "green", "blue"):
        points = world_points(lab, other)[:, :2]
        gaps = np.maximum(points.min(axis=0) - box[2:], box[:2] - points.max(axis=0))
        assert gaps.max() >= SPOT_MARGIN - 1e-9, other
    assert (box[1] + box[3]) / 2 > centre(lab, "plate")[1]  # on the plate's left (+y)


def test_the_motion_planner_reaches_a_pose_on_a_collision_free_path(motion):
    target = raised(grasp_pose(motion.env, "red"), APPROACH_HEIGHT)
    start = motion.current_qpos()
    status, postures = motion.ik(target, start)
    assert status == "Success"
    reached = start.copy()
    reached[:7] = postures[0][:7]
    assert np.allclose(motion.tcp_at(reached)[:3], target[:3], atol=1e-3)
    end = motion.move(start, target, "reach above the block")
    assert np.allclose(motion.tcp_at(end)[:3], target[:3], atol=0.01)
    assert len(motion.actions) > 0 and all(action[7] == 0.0 for action in motion.actions)
    posture = start.copy()
    for action in motion.actions:
        posture[:7] = action[:7]
        assert not motion.collides(posture)


def ik_targets(motion) -> list[np.ndarray]:
    """TCP poses over every object of the lab scene, and one far out of the arm's reach."""
    targets = [raised(grasp_pose(motion.env, name), APPROACH_HEIGHT) for name in ("red", "green", "blue", "mug")]
    far = targets[0].copy()
    far[:3] = [1.6, 0.0, 0.3]
    return [*targets, far]


def test_inverse_kinematics_finds_the_postures_mplib_finds_in_its_order(motion):
    from robolab_ms.policies.oracle.motion import seed_planner

    start = motion.current_qpos()
    for target in ik_targets(motion):
        flange = motion.flange_target(target)
        seed_planner(3)
        expected_status, expected = motion.planner.IK(flange, start)
        seed_planner(3)
        status, found = motion.flange_ik(flange, start)
        assert status == expected_status or (status.startswith("IK Failed") and expected_status.startswith("IK Failed"))
        assert len(found) == len(expected) and all(np.allclose(a, b) for a, b in zip(found, expected))


def test_inverse_kinematics_stops_at_the_first_posture_that_serves_and_draws_its_random_starts_all_the_same(motion):
    from robolab_ms.policies.oracle.motion import any_posture, seed_planner

    start = motion.current_qpos()
    target = motion.flange_target(ik_targets(motion)[0])
    seed_planner(5)
    _, every = motion.flange_ik(target, start)
    after_every = motion.flange_ik(target, start)[1]
    assert len(every) >= 2
    seed_planner(5)
    status, first = motion.flange_ik(target, start, serves=any_posture)
    assert status == "Success" and len(first) == 1 and np.allclose(first[0], every[0])
    assert all(np.allclose(a, b) for a, b in zip(motion.flange_ik(target, start)[1], after_every))
    seed_planner(5)
    status, second = motion.flange_ik(target, start, serves=lambda posture: not np.allclose(posture, every[0]))
    assert status == "Success" and np.allclose(second[0], every[1])  # the first is passed over
    seed_planner(5)
    status, none = motion.flange_ik(target, start, serves=lambda posture: False)
    assert status != "Success" and len(none) == len(every)  # none serves: every posture found, for a fallback


def test_inverse_kinematics_out_of_reach_finds_no_posture(motion):
    from robolab_ms.policies.oracle.motion import any_posture

    start = motion.current_qpos()
    far = motion.flange_target(ik_targets(motion)[-1])
    status, found = motion.flange_ik(far, start, serves=any_posture)
    assert status.startswith("IK Failed") and found == []
    assert not motion.can_lower(ik_targets(motion)[-1], ik_targets(motion)[-1])


def _flange_at(motion, posture: np.ndarray) -> np.ndarray:
    from robolab_ms.agents.droid_model import FLANGE_LINK

    model = motion.planner.pinocchio_model
    model.compute_forward_kinematics(posture)
    return np.asarray(model.get_link_pose(motion.planner.link_name_2_idx[FLANGE_LINK]))


def test_the_arm_reach_rules_out_no_pose_a_posture_reaches_and_the_poses_just_beyond_are_unreachable(motion):
    """Flange poses of random postures (a third of them with the elbow as straight as it goes, the wrist as far from
    the shoulder as it gets) are never out of reach; moved away from the shoulder until they are, just, mplib's
    inverse kinematics finds no posture for them either."""
    from robolab_ms.policies.oracle.motion import seed_planner
    from robolab_ms.policies.oracle.reach import ELBOW, REACH_MARGIN

    reach = motion.reach
    lower, upper = np.asarray(motion.planner.joint_limits).T
    rng = np.random.default_rng(0)
    start = motion.current_qpos()
    for index in range(300):
        posture = start.copy()
        posture[:7] = rng.uniform(lower[:7], upper[:7])
        if index % 3 == 0:
            posture[ELBOW] = upper[ELBOW]
        flange = _flange_at(motion, posture)
        assert reach.beyond(flange) <= 1e-6 and not reach.out_of_reach(flange)
        if index >= 12:
            continue
        outward = (flange[:3] - reach.shoulder) / np.linalg.norm(flange[:3] - reach.shoulder)
        near, far = 0.0, 1.0  # metres moved out: not yet beyond, and beyond
        for _ in range(30):
            moved = (near + far) / 2
            further = flange.copy()
            further[:3] += moved * outward
            near, far = (moved, far) if reach.beyond(further) < REACH_MARGIN + 1e-3 else (near, moved)
        further[:3] = flange[:3] + far * outward
        assert reach.out_of_reach(further)
        seed_planner(index)
        assert motion.planner.IK(further, start, n_init_qpos=50)[0].startswith("IK Failed")


def test_inverse_kinematics_out_of_reach_draws_its_random_starts_all_the_same(motion):
    """A pose out of reach is not searched, yet the search after it finds what it finds after mplib's full search."""
    from robolab_ms.policies.oracle.motion import seed_planner

    start = motion.current_qpos()
    far, near = (motion.flange_target(target) for target in (ik_targets(motion)[-1], ik_targets(motion)[0]))
    assert motion.reach.out_of_reach(far)
    seed_planner(4)
    motion.planner.IK(far, start)
    expected = motion.planner.IK(near, start)[1]
    seed_planner(4)
    status, nothing = motion.flange_ik(far, start)
    assert status.startswith("IK Failed") and nothing == []
    found = motion.flange_ik(near, start)[1]
    assert len(found) == len(expected) >= 2 and all(np.allclose(a, b) for a, b in zip(found, expected))


def test_points_inside_a_box_are_found_as_without_the_bounding_ball():
    from robolab_ms.policies.oracle.geometry import inside_boxes, rotation_about

    rng = np.random.default_rng(3)

    def brute_force(points, boxes, margin):
        return any(np.any(np.all(np.abs((points - c) @ r) <= h + margin, axis=1)) for r, c, h in boxes)

    hits = 0
    for _ in range(300):
        points = rng.normal(size=(40, 3)) * 0.05 + rng.uniform(-0.3, 0.3, size=3)
        axis = rng.normal(size=3)
        boxes = [
            (rotation_about(axis / np.linalg.norm(axis), rng.uniform(0, np.pi)), rng.uniform(-0.3, 0.3, 3), half)
            for half in rng.uniform(0.01, 0.15, size=(2, 3))
        ]
        expected = brute_force(points, boxes, 0.01)
        assert inside_boxes(points, boxes, 0.01) == expected
        hits += expected
    assert 30 < hits < 270  # both answers were checked


def test_the_pick_and_place_skill_puts_the_block_in_the_bin(motion):
    from robolab_ms.policies.oracle.skills import pick_and_place

    lab = motion.env
    pick_and_place(motion, "red", grasp_pose(lab, "red"), onto="bin")
    assert any(action[7] == 1.0 for action in motion.actions)  # it closes the hand on the way
    while motion.actions:
        lab.step(motion.actions.popleft())
    hold = motion.action(motion.current_qpos(), 0.0)
    for _ in range(10):
        lab.step(hold)
    assert bool(lab.evaluate()["success"][0])


def test_a_chain_of_straight_moves_is_the_same_timed_at_once_or_at_the_end(motion):
    """`straight_chain` times its moves once all are found; timing each as it is found gives the same paths."""
    from robolab_ms.policies.oracle.motion import MotionPlanner

    grasp = grasp_pose(motion.env, "red")
    poses = [raised(grasp, APPROACH_HEIGHT), raised(grasp, 0.05), grasp]
    start = motion.current_qpos()
    late = motion.straight_chain(start, poses)
    MotionPlanner.time_each_move = True
    try:
        early = motion.straight_chain(start, poses)
    finally:
        MotionPlanner.time_each_move = False
    assert late is not None and len(late) == len(poses)
    assert all(np.array_equal(a, b) for a, b in zip(late, early, strict=True))
    assert np.allclose(motion.tcp_at(np.concatenate([late[-1][-1], start[7:]]))[:3], grasp[:3], atol=2e-3)


def test_a_straight_move_follows_the_line_and_the_shortest_turn(motion):
    """Every waypoint of a straight move puts the flange on the line to the goal, turned by the same fraction of
    the shortest turn, at most STRAIGHT_STEP apart and STRAIGHT_TURN radians apart."""
    from scipy.spatial.transform import Rotation, Slerp

    from robolab_ms.policies.oracle.motion import FLANGE_LINK, STRAIGHT_STEP, STRAIGHT_TURN

    start = motion.current_qpos()
    goal_tcp = raised(grasp_pose(motion.env, "red"), APPROACH_HEIGHT)
    turn = Rotation.from_euler("z", 0.6) * Rotation.from_quat(np.roll(goal_tcp[3:], -1))
    goal_tcp[3:] = np.roll(turn.as_quat(), 1)  # (w, x, y, z)
    goal = motion.flange_target(goal_tcp)
    waypoints = motion.straight_waypoints(goal, start)
    assert waypoints is not None and len(waypoints) > 10

    model, flange = motion.planner.pinocchio_model, motion.planner.link_name_2_idx[FLANGE_LINK]

    def flange_at(joints: np.ndarray) -> np.ndarray:
        model.compute_forward_kinematics(np.concatenate([joints, start[7:]]))
        return np.asarray(model.get_link_pose(flange))

    first = flange_at(waypoints[0])
    turns = Rotation.from_quat([np.roll(first[3:], -1), np.roll(goal[3:], -1)])
    shortest = Slerp([0.0, 1.0], turns)
    count = len(waypoints) - 1
    reached = [flange_at(joints) for joints in waypoints]
    for index, pose in enumerate(reached[1:], start=1):
        fraction = index / count
        assert np.allclose(pose[:3], first[:3] + fraction * (goal[:3] - first[:3]), atol=1e-3)
        off = (shortest(fraction).inv() * Rotation.from_quat(np.roll(pose[3:], -1))).magnitude()
        assert off < 2e-3, (index, off)
    for before, after in zip(reached, reached[1:]):
        assert np.linalg.norm(after[:3] - before[:3]) <= STRAIGHT_STEP + 2e-3
        step_turn = Rotation.from_quat(np.roll(before[3:], -1)).inv() * Rotation.from_quat(np.roll(after[3:], -1))
        assert step_turn.magnitude() <= STRAIGHT_TURN + 4e-3


def test_a_carried_object_is_kept_clear_of_a_shelf_post():
    """Over a post of the wire shelf, with the hand clear of it, a mug hanging below the fingers would hit it: the
    posture collides while the planner carries the mug (`carrying`), and not before or after. The post is narrower
    than the mug: it passes between the mug's corners, so the check is of boxes, not of points."""
    from robolab_ms.envs import RoboLabEnv
    from robolab_ms.policies.oracle.motion import MotionPlanner, seed_planner
    from robolab_ms.policies.oracle.world import fixture_boxes

    env = RoboLabEnv(task="PutTwoMugsOnShelf", obs_mode="state_dict", render_backend="cpu")
    try:
        env.reset(seed=0)
        seed_planner(0)
        planner = MotionPlanner(env)
        planner.bind(env)
        planner.sync_fixtures()
        _, centre, half = min(fixture_boxes(env), key=lambda box: float(np.linalg.norm(box[1][:2])))  # nearest post
        top = centre[2] + half[2]
        over_post = np.concatenate([[centre[0], centre[1], top + 0.06], down_quaternion(np.array([0.0, 1.0]))])
        start = planner.current_qpos()
        status, postures = planner.ik(over_post, start)
        assert status == "Success"
        posture = start.copy()
        posture[:7] = postures[0][:7]
        mug = np.array([[x, y, z] for x in (-0.04, 0.04) for y in (-0.04, 0.04) for z in (0.0, 0.1)])  # below the TCP
        assert not planner.collides(posture)
        with planner.carrying(mug):
            assert planner.collides(posture)
            assert planner.plan_to_joints([posture], start)["status"] != "Success"  # the sampled planner too
        assert not planner.collides(posture)
        assert planner.ik(over_post, start)[0] == "Success"  # the mug's box is left out of the checks again
    finally:
        env.close()


class _Moves:
    """A stand-in for MotionPlanner's queue that refuses the joint path straight to `refused` poses and records
    the poses moved to."""

    def __init__(self, refused: list[np.ndarray]) -> None:
        self.refused, self.moved = refused, []

    def mark(self) -> int:
        return len(self.moved)

    def rewind(self, mark: int) -> None:
        del self.moved[mark:]

    def move(self, qpos, pose, what, straight=True):
        from robolab_ms.policies.oracle.failure import OracleFailure

        if not straight and any(np.array_equal(pose, refused) for refused in self.refused) and not self.moved:
            raise OracleFailure(f"cannot {what}")
        self.moved.append(pose.copy())
        return qpos


def test_a_carry_refused_on_the_way_rises_to_the_place_height_first():
    """Where no joint path from the lifted pose to the pose over the place keeps the held object clear, the carry
    goes straight up to that pose's height and across from there; a place lower than the lifted pose has no such
    way round and the failure stands."""
    from robolab_ms.policies.oracle.failure import OracleFailure
    from robolab_ms.policies.oracle.skills import carry_over

    down = down_quaternion(np.array([0.0, 1.0]))
    lifted = np.concatenate([[0.6, -0.15, 0.2], down])
    over_shelf = np.concatenate([[0.4, 0.3, 0.6], down])
    moves = _Moves(refused=[over_shelf])
    carry_over(moves, np.zeros(9), lifted, over_shelf, "carry the mug")
    assert len(moves.moved) == 2
    assert np.allclose(moves.moved[0][:3], [0.6, -0.15, 0.6]) and np.array_equal(moves.moved[1], over_shelf)

    below = np.concatenate([[0.4, 0.3, 0.1], down])
    moves = _Moves(refused=[below])
    with pytest.raises(OracleFailure):
        carry_over(moves, np.zeros(9), lifted, below, "carry the mug")
    assert moves.moved == []


@pytest.fixture
def jugs():
    """JugsOnShelf at seed 0: a 28-cm jug (a 9.7-cm body, wider than the open fingers, under a 4-cm neck) stands
    on the table, and the storage rack's top is 40 cm up."""
    with task_at_reset("JugsOnShelf", 0) as env:
        yield env


def test_a_bottle_whose_neck_fits_the_fingers_is_held_round_its_neck(jugs):
    """The jug's body is too wide for the fingers, but its neck, where the fingers close, is not: the grasp goes
    through the neck's middle (a chord of the wide body, off the middle, closed on air above the shoulder)."""
    from robolab_ms.policies.oracle.world import world_points

    points = world_points(jugs, "utilityjug_a01")
    top = points[:, 2].max()
    neck = points[points[:, 2] > top - 0.03]
    neck_middle = (neck[:, :2].max(axis=0) + neck[:, :2].min(axis=0)) / 2
    assert float(np.ptp(points[:, 0])) > OPEN_FINGER_GAP  # the body does not fit
    grasp = grasp_pose(jugs, "utilityjug_a01")
    assert np.linalg.norm(grasp[:2] - neck_middle) < 0.01
    assert grasp[2] > top - 0.04  # at the neck, above the shoulder


def test_a_screw_motion_that_spins_the_arm_round_is_refused(jugs):
    """Straight up from over the jug to 78 cm, mplib's screw motion turns the joints through about 17 rad (a
    90-second move near a singularity); `screw` refuses it, and keeps the short one up to 60 cm."""
    from robolab_ms.policies.oracle.motion import MAX_SCREW_TRAVEL, MotionPlanner, seed_planner

    seed_planner(0)
    motion = MotionPlanner(jugs)
    motion.bind(jugs)
    motion.sync_fixtures()
    grasp = grasp_pose(jugs, "utilityjug_a01")
    start = motion.current_qpos()
    status, postures = motion.ik(raised(grasp, 0.416 - grasp[2]), start)
    assert status == "Success"
    start[:7] = postures[0][:7]
    high, low = (motion.flange_target(raised(grasp, height - grasp[2])) for height in (0.78, 0.6))
    spin = motion.planner.plan_screw(high, start, time_step=motion.time_step)
    assert spin["status"] == "Success"
    assert np.abs(np.diff(spin["position"], axis=0)).max(axis=1).sum() > MAX_SCREW_TRAVEL
    assert motion.screw(high, start)["status"] != "Success"
    assert motion.screw(low, start)["status"] == "Success"


def test_seeding_the_planner_repeats_a_sampled_path(motion):
    """After `seed_planner`, OMPL's sampled path round a wall is the same every time for one seed, and another
    seed gives another path: a seed's episode does not depend on the episodes run before it in the process."""
    from robolab_ms.policies.oracle.motion import seed_planner

    wall = np.stack(np.meshgrid(np.linspace(0.3, 0.7, 20), [-0.02, 0.0, 0.02], np.linspace(0.0, 0.6, 30)), -1)
    motion.planner.update_point_cloud(wall.reshape(-1, 3))
    start = np.array([0.6, 0.4, 0.0, -2.0, 0.0, 2.4, 0.8, 0.04, 0.04])
    goal = start * np.array([-1, 1, 1, 1, 1, 1, 1, 1, 1])  # the same posture on the wall's other side

    def sampled_path(seed: int) -> np.ndarray:
        seed_planner(seed)
        result = motion.planner.plan_qpos_to_qpos([goal], start, time_step=0.05, use_point_cloud=True)
        assert result["status"] == "Success"
        return result["position"]

    first, other, again = sampled_path(7), sampled_path(8), sampled_path(7)
    assert np.array_equal(first, again)
    assert first.shape != other.shape or not np.allclose(first, other)


def hand_meets_block(planner, qpos: np.ndarray, point: np.ndarray) -> bool:
    """Whether the hand of mplib `planner` at joints `qpos` meets a 1-cm block at world `point`."""
    import mplib.pymp as mp

    fcl = mp.collision_detection.fcl
    planner.set_normal_object("block", fcl.CollisionObject(fcl.Box(np.full(3, 0.01)), point, np.array([1.0, 0, 0, 0])))
    try:
        return any(hit.link_name1 == "panda_hand" for hit in planner.check_for_env_collision(qpos=qpos))
    finally:
        planner.remove_normal_object("block")


def test_the_planner_checks_the_robots_own_hand(motion):
    """The planner's collision model carries the droid's 2F-85 (16 cm from the flange to the TCP), not the Panda hand
    of ManiSkill's arm model (10 cm): a block between the open pads, where only the 2F-85 reaches, is a collision
    for the planner, and one 3 cm beyond the fingertips is not. Without it a sampled path ran the pads into a shelf
    board."""
    import mplib

    from robolab_ms.agents.droid_model import FLANGE_LINK, panda_model

    qpos = motion.current_qpos()
    tcp = motion.tcp_at(qpos)
    axis = quat_to_matrix(tcp[3:])[:, 2]  # towards the fingertips
    panda_hand = mplib.Planner(urdf=str(panda_model()[0]), srdf=str(panda_model()[1]), move_group=FLANGE_LINK)

    assert hand_meets_block(motion.planner, qpos, tcp[:3] - 0.02 * axis)
    assert not hand_meets_block(panda_hand, qpos, tcp[:3] - 0.02 * axis)  # the arm model's own hand stops short
    assert not hand_meets_block(motion.planner, qpos, tcp[:3] + 0.03 * axis)


def test_a_shorter_hand_keeps_the_part_of_the_solids_in_front_of_its_flange():
    """For the Panda robot's own hand (TCP 10.3 cm from the flange) the planning model keeps the gripper's solids as
    far as they lie in front of the flange: a block 3 cm from the flange, inside the hand's body, is a collision;
    one behind the flange, where the wrist is the arm model's own link, is not the hand's."""
    import mplib

    from robolab_ms.agents.droid_model import FLANGE_LINK, panda_model
    from robolab_ms.policies.oracle.planning_model import planning_urdf

    planner = mplib.Planner(
        urdf=str(planning_urdf(np.array([0.0, 0.0, 0.1034, 1.0, 0.0, 0.0, 0.0]))),
        srdf=str(panda_model()[1]),
        move_group=FLANGE_LINK,
    )
    qpos = np.array([0.0, -0.6, 0.0, -2.5, 0.0, 1.9, 0.8, 0.04, 0.04])
    model = planner.pinocchio_model
    model.compute_forward_kinematics(qpos)
    flange = np.asarray(model.get_link_pose(planner.link_name_2_idx[FLANGE_LINK]))
    axis = quat_to_matrix(flange[3:])[:, 2]

    assert hand_meets_block(planner, qpos, flange[:3] + 0.03 * axis)
    assert not hand_meets_block(planner, qpos, flange[:3] - 0.03 * axis)


def test_a_screw_motion_that_crawls_is_refused():
    """A screw motion that moves the joints little but lasts longer than MAX_SCREW_SECONDS (tiny steps near a
    singularity) is refused like one that spins the arm round; a short one is kept."""
    from types import SimpleNamespace

    from robolab_ms.policies.oracle.motion import MAX_SCREW_SECONDS, MotionPlanner

    steps = {"count": 0}

    def plan_screw(flange_pose, qpos, time_step):
        path = np.linspace(qpos[:7], qpos[:7] + 0.07, steps["count"])  # 0.07 rad on every joint in all
        return {"status": "Success", "position": path}

    motion = MotionPlanner.__new__(MotionPlanner)
    motion.env = SimpleNamespace(control_freq=15)
    motion.planner = SimpleNamespace(plan_screw=plan_screw)
    start = np.zeros(9)
    steps["count"] = int(MAX_SCREW_SECONDS * 15) + 50  # a 4-cm lift that took 29 s in ToolsPickingAllHammers
    refused = motion.screw(np.zeros(7), start)
    assert refused["status"] != "Success" and "crawls" in refused["status"]
    steps["count"] = 30  # two seconds
    assert motion.screw(np.zeros(7), start)["status"] == "Success"
