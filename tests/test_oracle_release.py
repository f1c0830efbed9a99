"""Where the oracle releases an object at the edge of its reach over a large bin (policies/oracle/places.py)."""

import numpy as np

from robolab_ms.policies.oracle.places import PLACE_REACH_MARGIN, backed_off

DOWN = np.array([0.0, 1.0, 0.0, 0.0])  # a top-down TCP (w, x, y, z): 180 degrees about x


def poses(xs: list[float], y: float = 0.0) -> list[np.ndarray]:
    return [np.array([x, y, 0.1, *DOWN]) for x in xs]


def test_the_release_moves_in_from_the_edge_when_a_second_object_still_fits():
    held = np.array([[-0.02, -0.02], [0.02, 0.02]])  # a 4-cm object
    free = poses([0.50, 0.54, 0.58, 0.62, 0.66, 0.70])
    found = (free[-1], free[-1])  # the farthest spot reached: at the edge of the reach
    chosen, _ = backed_off(free, found, lambda pose: (pose, pose), held, free[-1])
    assert float(chosen[0]) <= 0.70 - PLACE_REACH_MARGIN + 1e-9
    assert float(chosen[0]) == max(x for x in (0.50, 0.54, 0.58, 0.62, 0.66) if x <= 0.70 - PLACE_REACH_MARGIN)


def test_the_release_stays_at_the_edge_when_no_room_would_be_left_for_a_second_object():
    held = np.array([[-0.15, -0.02], [0.15, 0.02]])  # a 30-cm hammer along x: no two fit in 24 cm of floor
    free = poses([0.50, 0.54, 0.58, 0.62, 0.66, 0.70, 0.74])
    found = (free[-1], free[-1])
    chosen, _ = backed_off(free, found, lambda pose: (pose, pose), held, free[-1])
    assert float(chosen[0]) == 0.74


def test_the_release_stays_where_it_was_when_the_nearer_spot_is_not_reached():
    held = np.array([[-0.02, -0.02], [0.02, 0.02]])
    free = poses([0.50, 0.54, 0.58, 0.62, 0.66, 0.70])
    found = (free[-1], free[-1])
    chosen, _ = backed_off(free, found, lambda pose: None, held, free[-1])
    assert float(chosen[0]) == 0.70


def test_the_fallback_release_over_a_bin_clears_what_already_sticks_out_of_it():
    """Where no free spot is found, the held object goes over the middle of the bin: above the keyboard that leans
    over the bin's rim in workdesk_bin, not at the rim's height where it would push into it."""
    import gymnasium as gym

    from robolab_ms.policies.oracle.grasps import grasp_pose
    from robolab_ms.policies.oracle.places import place_pose
    from robolab_ms.policies.oracle.world import object_bottom, world_points
    from robolab_ms.tasks.spec import load_task

    env = gym.make(load_task("BlackItemsInBin").env_id, obs_mode="state_dict")
    try:
        env.reset(seed=0)
        base = env.unwrapped
        base.eval_context.refresh()
        keyboard_top = float(world_points(base, "keyboard")[:, 2].max())
        rim = float(world_points(base, "grey_bin")[:, 2].max())
        assert keyboard_top > rim + 0.05  # it sticks out well over the rim
        grasp = grasp_pose(base, "glasses")
        held_bottom = grasp[2] - object_bottom(base, "glasses")
        place, _ = place_pose(base, "glasses", "grey_bin", None, grasp, held_bottom, np.zeros(2))
        assert place[2] - held_bottom > keyboard_top  # the glasses' bottom is let go above the keyboard
    finally:
        env.close()
