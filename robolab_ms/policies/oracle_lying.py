"""The oracle's stand-up-first skill: a container lying on its side (a mug) that is to go into another container.

A top-down grasp of a lying mug lands the open fingers on its round body (the body is about as wide as the fingers'
gap, and its points say little about where it bulges), and a mug held across its lying body twists out on the way.
Stood up first (held by the top of its rim and tipped up about its base, as `upright` tasks do), it is then held by
its wall at the rim like any standing mug. Where the tip cannot be planned the object is grasped as it lies.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv
    from robolab_ms.policies.oracle import Job, OraclePolicy

LYING_TILT = 1.0  # rad: a container tilted this far lies on its side (its opening faces sideways, not up or down)
UPSIDE_DOWN_TILT = 2.2  # rad: tilted further, its opening faces down (a tip about its base cannot stand it up)


def lying_container(env: RoboLabEnv, name: str) -> bool:
    """Whether object `name` is a container lying on its side, its opening facing sideways."""
    from robolab_ms.policies.oracle import _tilt

    if env.scene.gpu_sim_enabled or not env.eval_context.entries[name].is_container:
        return False
    return LYING_TILT < _tilt(env, name) < UPSIDE_DOWN_TILT


def stand_before_moving(policy: OraclePolicy, job: Job) -> bool:
    """Queue the tip that stands `job.obj` up and put the move itself back at the front of the policy's jobs; False
    (nothing queued) where it no longer lies or the tip cannot be planned."""
    from robolab_ms.policies.oracle import Job as PlainJob
    from robolab_ms.policies.oracle import OracleFailure

    if not lying_container(policy.env, job.obj):
        return False
    planned = len(policy.actions)
    try:
        policy._plan_reorientation(job.obj)
    except OracleFailure:
        while len(policy.actions) > planned:
            policy.actions.pop()
        return False
    policy.jobs.appendleft(PlainJob(job.obj, onto=job.onto, centred=job.centred))
    return True
