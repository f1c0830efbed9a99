"""Events against physics: each fires once when its situation arises and re-arms when it clears."""

import math

import numpy as np
import pytest
from helpers import hold_arm_action, put

from robolab_ms.tasks.events import EVENT_TYPES

TABLE_TOUCH_QPOS = [0.0, 0.9, 0.0, -1.6, 0.0, 2.5, 0.785]  # fingertips at the table top, between blocks
TRIGGERED = set()


@pytest.fixture()
def env(lab):
    return lab


def run(env, steps=8, gripper=0.0, arm=None):
    """Step with the arm held (or sent to `arm`); returns the event types that fired."""
    if arm is None:
        action = hold_arm_action(env, gripper)
    else:
        action = np.array([*arm, gripper], dtype=np.float32)
    fired = set()
    for _ in range(steps):
        _, _, _, _, info = env.step(action)
        fired |= {kind for kind in EVENT_TYPES if bool(info[f"event_{kind}"][0])}
    TRIGGERED.update(fired)
    return fired


def grasp(env, name):
    actor = env.objects[name]
    tcp = env.agent.tcp.pose
    actor._bodies[0].disable_gravity = True
    put(env, name, tcp.p[0].tolist(), tuple(tcp.q[0].tolist()))
    fired = run(env, steps=6, gripper=1.0)
    actor._bodies[0].disable_gravity = False
    return fired | run(env, steps=4, gripper=1.0)


def logged(env, kind):
    return [event for event in env.task_evaluator.events.log[0] if event["type"] == kind]


def test_quiet_episode_has_no_events(env):
    assert run(env, steps=10) == set()
    assert env.task_evaluator.events.log[0] == []


def test_grasping_a_non_target(env):
    fired = grasp(env, "blue")
    assert {"wrong_object_grasped", "gripper_hit_object"} <= fired
    assert logged(env, "wrong_object_grasped")[0]["object"] == "blue"
    assert run(env, steps=5, gripper=1.0) == set()  # still held: nothing new


def test_grasping_the_target_then_dropping_it(env):
    fired = grasp(env, "red")
    assert "wrong_object_grasped" not in fired and "gripper_hit_object" not in fired
    assert "target_dropped" in run(env, steps=15, gripper=0.0)
    assert logged(env, "target_dropped")[0]["object"] == "red"


def test_closing_on_nothing(env):
    fired = run(env, steps=10, gripper=1.0)
    assert "gripper_fully_closed" in fired
    run(env, steps=10, gripper=0.0)
    assert "gripper_fully_closed" in run(env, steps=10, gripper=1.0)  # re-armed after opening
    assert len(logged(env, "gripper_fully_closed")) == 2


def test_two_objects_in_the_hand(env):
    tcp = env.agent.tcp.pose
    across = tcp.to_transformation_matrix()[0, :3, 0]  # side by side, both between the fingers
    for name, shift in (("red", -0.026), ("green", 0.026)):
        env.objects[name]._bodies[0].disable_gravity = True
        put(env, name, (tcp.p[0] + shift * across).tolist(), tuple(tcp.q[0].tolist()))
    fired = run(env, steps=6, gripper=1.0)
    for name in ("red", "green"):
        env.objects[name]._bodies[0].disable_gravity = False
    assert "multiple_objects_grasped" in fired | run(env, steps=2, gripper=1.0)


def test_bumped_moved_out_of_scene_and_tipped(env):
    put(env, "blue", (0.8, 0.1, 0.026))
    assert "object_bumped" in run(env, steps=2)
    put(env, "blue", (0.3, -0.45, 0.026))
    assert "object_moved" in run(env, steps=2)
    put(env, "green", (3.0, 0.0, 0.5))
    assert "object_out_of_scene" in run(env, steps=1)
    lying = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)
    put(env, "mug", (0.75, -0.3, 0.045), lying)
    assert "object_tipped_over" in run(env, steps=4)
    assert [e["object"] for e in logged(env, "object_tipped_over")] == ["mug"]


def test_gripper_hits_table(env):
    env.set_arm_qpos(TABLE_TOUCH_QPOS)
    assert "gripper_hit_table" in run(env, steps=4, arm=TABLE_TOUCH_QPOS)


def test_every_event_type_is_exercised():
    assert set(EVENT_TYPES) - TRIGGERED == set()
