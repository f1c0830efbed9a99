"""The oracle's pieces for taking objects off a shelf level, on their own: the order of the jobs (the object nearest
the level's open side first, `compile.way_out_first`), the set-down spot on the table with the held object turned
about the vertical (`places.turned_table_place`) and a mug's wall grasp come down onto from over the rim
(`side_grasps.front_grasps`), the ways out (`side_grasps.ways_out`) and the straight moves in and out
(`skills.reach_in_and_out`), on TakeMugsOffOfShelf's rack at seed 0 (a white mug in front of a blue one on the
middle level, 11 cm under the level above)."""

import numpy as np
import pytest
from helpers import task_at_reset

from robolab_ms.policies.oracle.compile import way_out_first
from robolab_ms.policies.oracle.geometry import quat_to_matrix, rotation_about
from robolab_ms.policies.oracle.places import TABLE_TURNS, place_pose, turned_table_place
from robolab_ms.policies.oracle.side_grasps import front_grasps
from robolab_ms.policies.oracle.world import centre, fixture_boxes, object_bottom, open_side_depths, world_points


@pytest.fixture(scope="module")
def rack():
    with task_at_reset("TakeMugsOffOfShelf", 0) as env:
        yield env


def test_the_mug_in_front_is_taken_off_the_level_first(rack):
    boxes = fixture_boxes(rack)
    depth = {name: open_side_depths(world_points(rack, name), boxes)[0][0] for name in ("ceramic_mug", "mug")}
    assert depth["mug"] < depth["ceramic_mug"]  # the white mug stands nearer the open side
    assert way_out_first(rack, ["ceramic_mug", "mug"]) == ["mug", "ceramic_mug"]
    assert way_out_first(rack, ["mug", "ceramic_mug"]) == ["mug", "ceramic_mug"]


def test_objects_not_under_a_level_keep_their_places_in_the_order(rack):
    # the jug and the bowl stand on the table beside the rack: only the two mugs swap, in the slots they had
    order = ["utilityjug_a01", "ceramic_mug", "serving_bowl", "mug"]
    assert way_out_first(rack, order) == ["utilityjug_a01", "mug", "serving_bowl", "ceramic_mug"]


def test_a_held_object_is_turned_about_the_vertical_over_its_spot_until_the_hand_reaches(rack):
    grasp = front_grasps(rack, "mug")[0].pose
    held_offset = grasp[:2] - centre(rack, "mug")[:2]
    held_bottom = grasp[2] - object_bottom(rack, "mug")
    at = (0.33, -0.05)
    tried = []

    def reach_only_half_round(over, place):
        tried.append(place)
        return len(tried) == 2  # the object as it lies first, then half round (TABLE_TURNS' order)

    place, over = turned_table_place(rack, "mug", at, grasp, held_bottom, held_offset, reach_only_half_round)
    assert TABLE_TURNS[:2] == (0, 180) and len(tried) == 2
    as_held, _ = place_pose(rack, "mug", None, at, grasp, held_bottom, held_offset)
    assert np.allclose(tried[0], as_held)  # no turn first
    spin = rotation_about(np.array([0.0, 0.0, 1.0]), np.pi)
    assert np.allclose(quat_to_matrix(place[3:]), spin @ quat_to_matrix(grasp[3:]), atol=1e-6)
    # the object's middle stays over the spot: the hand goes round it to the other side
    assert np.allclose(place[:2], np.asarray(at) - held_offset, atol=1e-6)
    assert np.isclose(place[2], as_held[2]) and over[2] > place[2]
    # the hand leaned out towards the robot; turned half round, it leans away from it
    lean_before, lean_after = -quat_to_matrix(grasp[3:])[:2, 2], -quat_to_matrix(place[3:])[:2, 2]
    assert lean_before @ -np.asarray(at) > 0 > lean_after @ -np.asarray(at)


def test_no_turn_reached_leaves_no_place(rack):
    grasp = front_grasps(rack, "mug")[0].pose
    calls = []

    def never_reached(over, place):
        calls.append(place)
        return False

    found = turned_table_place(rack, "mug", (0.33, -0.05), grasp, 0.1, np.zeros(2), never_reached)
    assert found is None and len(calls) == len(TABLE_TURNS)


def test_a_mug_on_the_level_is_held_by_its_wall_with_the_hand_coming_down_from_over_the_rim(rack):
    from robolab_ms.policies.oracle.gripper import hand_clear
    from robolab_ms.policies.oracle.side_grasps import pad_corner_drop

    grasps = front_grasps(rack, "mug")
    assert grasps
    first = grasps[0]
    rim = float(world_points(rack, "mug")[:, 2].max())
    assert np.allclose(first.approach[:2], first.pose[:2]) and np.allclose(first.approach[3:], first.pose[3:])
    lean = np.arccos(np.clip(-quat_to_matrix(first.pose[3:])[2, 2], -1.0, 1.0))
    assert first.approach[2] - pad_corner_drop(lean) > rim  # the pads pass over the rim, then come down onto it
    assert first.pose[2] < rim  # closed on the wall below the rim
    assert hand_clear(first.approach, fixture_boxes(rack)) and hand_clear(first.entry, fixture_boxes(rack))
    # the hand moves in level from outside the shelf to over the rim
    assert (
        np.isclose(first.entry[2], first.approach[2]) and first.entry[:2] @ first.out > first.approach[:2] @ first.out
    )


def test_the_ways_out_start_along_the_grasp_and_leave_every_footprint_level(rack):
    from robolab_ms.policies.oracle.geometry import Box, inside_boxes, raised
    from robolab_ms.policies.oracle.side_grasps import FRONT_LIFT, ways_out

    # a hand leaning out 20 degrees off the level's open side: out along its own lean first, then by that side
    candidates = [(grasp, ways_out(rack, "mug", grasp)) for grasp in front_grasps(rack, "mug")]
    grasp, outs = next((grasp, outs) for grasp, outs in candidates if len(outs) > 1)
    lifted = raised(grasp.pose, FRONT_LIFT)
    sides = [side for _, side in open_side_depths(world_points(rack, "mug"), fixture_boxes(rack))]
    held = world_points(rack, "mug") - grasp.pose[:3]
    tall: list[Box] = [(rotation, middle, half + [0.0, 0.0, 1.0]) for rotation, middle, half in fixture_boxes(rack)]
    for index, out in enumerate(outs):
        moved = out[:3] - lifted[:3]
        assert moved[2] == pytest.approx(0.0) and np.allclose(out[3:], lifted[3:])  # level, the hand as it held
        direction = moved[:2] / np.linalg.norm(moved[:2])
        assert np.allclose(direction, grasp.out) if index == 0 else any(np.allclose(direction, s) for s in sides)
        assert not inside_boxes(held + out[:3], tall, 0.0)  # the mug is out from under the level


def test_the_hand_goes_in_under_the_level_and_out_again_in_straight_lines(rack):
    from robolab_ms.policies.oracle.geometry import raised
    from robolab_ms.policies.oracle.motion import MotionPlanner, seed_planner
    from robolab_ms.policies.oracle.side_grasps import FRONT_LIFT, ways_out
    from robolab_ms.policies.oracle.skills import reach_in_and_out

    seed_planner(0)
    motion = MotionPlanner(rack)
    motion.bind(rack)
    motion.sync_fixtures()
    grasp = front_grasps(rack, "mug")[0]
    outs = ways_out(rack, "mug", grasp)
    entry_joints, paths, out = reach_in_and_out(motion, "mug", grasp, outs)
    assert any(out is candidate for candidate in outs)
    assert np.allclose(motion.tcp_at(entry_joints)[:3], grasp.entry[:3], atol=0.002)
    ends = [grasp.entry, grasp.approach, grasp.pose, raised(grasp.pose, FRONT_LIFT), out]
    posture = entry_joints.copy()
    for path, start, end in zip(paths, ends, ends[1:]):
        line = end[:3] - start[:3]
        for joints in path:
            posture[:7] = joints
            offset = motion.tcp_at(posture)[:3] - start[:3]
            along = float(np.clip(offset @ line / (line @ line), 0.0, 1.0))
            assert np.linalg.norm(offset - along * line) < 0.003  # on the line between the two poses
        assert np.allclose(motion.tcp_at(posture)[:3], end[:3], atol=0.01)
