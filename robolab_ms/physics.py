"""The simulation's physics settings that every part shares: the physics rate, and when objects count as at rest.

The policy's rate is CONTROL_HZ in robolab_ms.tasks.spec; this module imports nothing, so that the catalog check,
the environments, task validation and scene generation all read the same numbers.
"""

SIM_HZ = 120  # physics steps per second, in episodes and in the catalog check's scenes
STABILITY_PHYSICS_STEPS = 300  # physics steps objects must stay put at rest (the arm still) ...
MAX_DRIFT_M = 0.02  # ... moving at most this far (m): a scene is stable, a catalog object stays put
