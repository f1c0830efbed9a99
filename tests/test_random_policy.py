"""The random policy draws the actions of numpy's `uniform` over the action space, from the episode's seed."""

import numpy as np
from gymnasium import spaces

from robolab_ms.policies import RandomPolicy


def test_the_draws_are_numpys_uniform_over_the_bounds():
    low = np.array([[-2.9, -1.76, -2.9, -3.07, -2.9, -0.02, -2.9, 0.0]], dtype=np.float32)
    high = np.array([[2.9, 1.76, 2.9, -0.07, 2.9, 3.75, 2.9, 1.0]], dtype=np.float32)
    space = spaces.Box(low, high, dtype=np.float32)
    policy = RandomPolicy()
    policy.reset("", space, seed=5)
    reference = spaces.Box(low, high, dtype=np.float32)
    reference.seed(5)
    for _ in range(2000):
        action = policy.act({})
        assert action.dtype == np.float32 and space.contains(action)
        assert np.array_equal(action, reference.np_random.uniform(low, high, size=low.shape).astype(np.float32))


def test_a_space_unbounded_on_a_side_is_sampled_as_gymnasium_samples_it():
    space = spaces.Box(np.array([-1.0, -np.inf], dtype=np.float32), np.array([1.0, 2.0], dtype=np.float32))
    policy = RandomPolicy()
    policy.reset("", space, seed=2)
    reference = spaces.Box(space.low, space.high, dtype=np.float32)
    reference.seed(2)
    for _ in range(100):
        assert np.array_equal(policy.act({}), reference.sample())
