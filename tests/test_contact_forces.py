"""The contact forces the task logic reads on the CPU simulator: a pair's contact impulses summed and divided by
the physics time step, on the body asked about."""

import numpy as np
import pytest
from helpers import hold_arm_action, put


def impulses_on(env, name: str, other: str) -> np.ndarray:
    """The impulse on `name` from `other` this physics step, summed in numpy from PhysX's contacts."""
    names = env.eval_context._body_names
    total = np.zeros(3)
    for contact in env.scene.px.get_contacts():
        pair = tuple(names.get(body) for body in contact.bodies)
        for point in contact.points:
            if pair == (name, other):
                total += point.impulse  # PhysX's impulse on the contact's first body
            elif pair == (other, name):
                total -= point.impulse
    return total


@pytest.mark.parametrize("support", ["table", "plate"])
def test_a_block_is_held_up_with_its_weight_and_the_sum_is_numpys(lab, support):
    """The red block on the table, or on the plate (PhysX names the block first there, the plate first by name)."""
    if support == "plate":
        plate = lab.objects["plate"].pose.p[0].numpy()
        put(lab, "red", (plate[0], plate[1], plate[2] + 0.04))
    action = hold_arm_action(lab, 0.0)
    for _ in range(30):  # the block settles
        lab.step(action)
    context = lab.eval_context
    weight = float(lab.objects["red"].mass[0]) * 9.81
    for _ in range(3):
        lab.step(action)
        context.refresh()
        force = context.force_on("red", support)[0].numpy()
        expected = impulses_on(lab, "red", support) / lab.scene.px.timestep
        assert np.array_equal(force, expected.astype(np.float32))
        assert abs(force[2] - weight) < 0.05 * weight and np.linalg.norm(force[:2]) < 0.05 * weight
        assert np.array_equal(context.force_on(support, "red")[0].numpy(), -force)
