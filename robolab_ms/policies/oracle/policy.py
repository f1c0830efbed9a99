"""The oracle's execution: a closed loop over the jobs of the task's success condition (see `compile`).

It plans one job (one object) at a time from the state it finds, with the skill the object's situation calls
for, and replays the queued actions. A held object that falls away from the closed hand ends its job's moves at
once; when a job's moves are over it checks the task's condition for that object, and a job that did not get
there (the object slipped, tipped or was never held) is planned again from the new state, up to JOB_RETRIES times,
with a different grasp first. A job that cannot be planned at all goes after the others, since moving them may
free its way; the first DEFERRALS times it waits without using up a retry, unless none of the jobs queued can
be planned. Where the condition asks for only some of its objects, a job given up hands over to a spare one
on another of them. Once every retry is used up, the objects still out of place have their jobs planned one last
time from where they came to rest. When it cannot go on it raises OracleFailure saying why.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from robolab_ms.policies import Policy
from robolab_ms.policies.oracle.compile import Job, job_done, jobs_for, spare_jobs
from robolab_ms.policies.oracle.failure import OracleFailure
from robolab_ms.policies.oracle.grasps import grasp_pose
from robolab_ms.policies.oracle.motion import GRIPPER_STEPS, SETTLE_STEPS, MotionPlanner, seed_planner
from robolab_ms.policies.oracle.places import crowded_top
from robolab_ms.policies.oracle.side_grasps import side_grips
from robolab_ms.policies.oracle.skills import (
    front_pick_and_place,
    lift_out_standing,
    pick_and_place,
    side_hold_pick_and_place,
    stand_upright,
    tip_onto_side,
    upside_down,
)
from robolab_ms.policies.oracle.world import covered, leaning_board, lying_container

if TYPE_CHECKING:
    from robolab_ms.envs.robolab_env import RoboLabEnv

TIPS = 3  # times an upside-down object is pushed over before its job gives up
DEFERRALS = 1  # times a job that cannot be planned may wait for the others without using up a retry
JOB_RETRIES = 2  # times a job whose object did not get where the condition wants it is planned again
JOB_SETTLE_STEPS = 10  # control steps held still before a job's object is checked a second time (it may still roll)
GIVE_UP_STEPS = 30  # control steps the objects not where they belong lie still, once every job's retries are used
# up, before the oracle gives up (while one still moves, it may come to rest where it belongs: the oracle waits)
GIVE_UP_WAIT_STEPS = 300  # control steps at most waited for those objects to lie still before the last try
REST_CHECK_STEPS = 10  # control steps held still between two looks at whether those objects lie still
REST_SPEED = 0.01  # m/s (and rad/s): an object slower than this, moving and turning, lies still
SLIP_DISTANCE = 0.05  # m the held object may move away from the hand (its grip settled) before it counts as slipped


class OraclePolicy(Policy):
    """Solves tasks from privileged simulator state; the upper-bound row of a results table."""

    name = "oracle"
    needs_images = False
    privileged = True

    def __init__(self) -> None:
        self.env: RoboLabEnv | None = None
        self.motion: MotionPlanner | None = None

    @property
    def actions(self) -> deque[np.ndarray]:
        """The actions queued and not yet sent."""
        return self.motion.actions if self.motion is not None else deque()

    def bind(self, env: Any) -> None:
        """Give the oracle the environment whose true state it reads (the unwrapped RoboLabEnv)."""
        self.env = env.unwrapped
        if self.motion is None or self.motion.robot != self.env.robot_uids:
            self.motion = MotionPlanner(self.env)
        self.motion.bind(self.env)

    def reset(self, instruction: str, action_space: spaces.Box, seed: int) -> None:
        if self.env is None:
            raise OracleFailure("the oracle reads the simulator: call bind(env) before reset()")
        seed_planner(seed)
        self.motion.sync_fixtures()
        self.compiled: list[Job] = jobs_for(self.env)  # every job of the task, to look over once all are done
        self.jobs: deque[Job] = deque(self.compiled)
        self.spares: deque[Job] = deque(spare_jobs(self.env))  # for a job given up (any one or any k of objects)
        self.motion.actions.clear()
        self.motion.gripper = 0.0
        self.job: Job | None = None  # the job whose actions are being replayed
        self._job_settled = False  # whether the hand has held still once after it, before the second check
        self.retries: dict[str, int] = {}  # per object: jobs planned again
        self.tips: dict[str, int] = {}  # per object: pushes that tipped it (or tried to) from upside down
        self.grasps: dict[str, list[np.ndarray]] = {}  # per object: the grasps its jobs were planned with
        self._closed_steps = 0  # actions replayed in a row with the gripper closed
        self._held_offset: float | None = None  # the held object's distance from the hand once the grip settled
        self._still_steps = 0  # steps the objects left where they do not belong have lain still, retries used up
        self._waited_steps = 0  # steps held still since every job's retries were used up, for the objects left
        self._last_tried: set[str] = set()  # objects whose jobs had their last try (see `_last_try`)
        self._deferred: dict[str, int] = {}  # per object: times its job waited for the others without a retry
        self._unplanned: set[str] = set()  # objects whose jobs failed to plan since the last plan that worked

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        motion = self.motion
        while not motion.actions:
            if self.job is not None and self._check_job():
                continue  # the hand holds still a moment before the job is checked again
            if not self.jobs and not self._undone():
                left = [job.obj for job in self.compiled if not job_done(self.env, job)]
                if not left:  # everything done: hold still with the gripper open
                    return motion.action(motion.current_qpos(), 0.0)
                if self._still_steps >= GIVE_UP_STEPS or self._waited_steps >= GIVE_UP_WAIT_STEPS:
                    if self._last_try(left):
                        continue
                    raise OracleFailure(  # the episode would only run out its time
                        f"gave up on {', '.join(repr(name) for name in left)}: not where the task wants "
                        f"after {JOB_RETRIES} retries and a last try each"
                    )
                self._still_steps = self._still_steps + REST_CHECK_STEPS if self._lie_still(left) else 0
                self._waited_steps += REST_CHECK_STEPS
                motion.hold(motion.current_qpos(), 0.0, REST_CHECK_STEPS)
                continue
            job = self.jobs.popleft()
            self.job, self._job_settled = job, False  # _plan_job may hand the check to a job it queues
            self._waited_steps = 0
            try:
                self._plan_job(job)
            except OracleFailure:
                self.job = None
                motion.actions.clear()  # a plan that failed half-way leaves nothing to replay
                if self._defer(job):
                    continue
                if not self._retry(job, first=False):
                    raise
                continue
            self._unplanned.clear()
        action = motion.actions.popleft()
        if self.job is not None and self._slipped(action):  # the rest of the job is moot: open, check, plan again
            motion.actions.clear()
            motion.hold(motion.current_qpos(), 0.0, GRIPPER_STEPS)
            action = motion.actions.popleft()
        return action

    # ------------------------------------------------------------------------------------------------ the loop
    def _slipped(self, action: np.ndarray) -> bool:
        """Whether the object of the job being replayed has fallen away from the closed hand: once the grip has
        settled, its distance from the TCP grew by more than SLIP_DISTANCE."""
        if action[7] < 0.5:
            self._closed_steps, self._held_offset = 0, None
            return False
        self._closed_steps += 1
        if self._closed_steps < GRIPPER_STEPS + SETTLE_STEPS:
            return False
        offset = float(np.linalg.norm((self.env.objects[self.job.obj].pose.p[0] - self.env.tcp_pose().p[0]).cpu()))
        if self._held_offset is None:
            self._held_offset = offset
        return offset > self._held_offset + SLIP_DISTANCE

    def _check_job(self) -> bool:
        """After a job's actions: whether its object satisfies the task's condition; if not, hold still once, the
        gripper as the job left it (True: actions were queued), and then plan the job again. Group conditions (a
        stack, an order) hold only when every job is done, so their jobs are not checked."""
        job = self.job
        if job_done(self.env, job):
            self.job = None
            return False
        if not self._job_settled:  # the hand keeps its grip: a lifted object may still be rising with the lagging arm
            self._job_settled = True
            self.motion.hold(self.motion.current_qpos(), self.motion.gripper, JOB_SETTLE_STEPS)
            return True
        self.job = None
        self._retry(job, first=True)  # with another grasp: the one that failed comes last (grasp_pose's `failed`)
        return False

    def _lie_still(self, names: list[str]) -> bool:
        """Whether every object of `names` moves and turns slower than REST_SPEED."""
        for name in names:
            actor = self.env.objects[name]
            speeds = (actor.linear_velocity[0], actor.angular_velocity[0])
            if any(float(np.linalg.norm(speed.cpu().numpy())) >= REST_SPEED for speed in speeds):
                return False
        return True

    def _undone(self) -> bool:
        """Once the queue is empty: queue again (within their retries) the jobs whose object no longer satisfies the
        task's condition (knocked out of a pot or over by a later job); whether any was queued."""
        undone = [job for job in self.compiled if not job_done(self.env, job)]
        queued = [job for job in undone if self._retry(job, first=False)]
        return bool(queued)

    def _last_try(self, left: list[str]) -> bool:
        """Once every job's retries are used up and the objects of `left`, not where the task wants them, lie still
        (or have moved for GIVE_UP_WAIT_STEPS): queue the job of each that has not had it once more, from where it
        came to rest (a dropped tool may lie where another grasp reaches it); whether any was queued."""
        jobs = [job for job in self.compiled if job.obj in left and job.obj not in self._last_tried]
        self._last_tried.update(job.obj for job in jobs)
        self.jobs.extend(jobs)
        self._still_steps = self._waited_steps = 0
        return bool(jobs)

    def _defer(self, job: Job) -> bool:
        """Put `job`, which could not be planned, after the others without using up one of its retries, unless
        every job in the queue has failed to be planned since the last plan that succeeded (moving the others may
        free its way; nothing moves while none can be planned) or it has waited so DEFERRALS times; whether it was
        put back."""
        if not self.jobs or job.obj in self._unplanned or self._deferred.get(job.obj, 0) >= DEFERRALS:
            return False
        self._unplanned.add(job.obj)
        self._deferred[job.obj] = self._deferred.get(job.obj, 0) + 1
        self.jobs.append(job)
        return True

    def _retry(self, job: Job, first: bool) -> bool:
        """Queue `job` again, at the front of the jobs when `first` (planned next), else after the others, unless
        its object has used up its retries; then, where the condition asks for only some of its objects, queue a
        spare job in its place (on another of them) instead. Whether a job was queued."""
        used = self.retries.get(job.obj, 0)
        if used >= JOB_RETRIES:
            return self._replace(job, first)
        self.retries[job.obj] = used + 1
        if first:
            self.jobs.appendleft(job)
        else:
            self.jobs.append(job)
        return True

    def _replace(self, job: Job, first: bool) -> bool:
        """Give `job` up for the next spare job (where the condition asks for only some of its objects), queued
        where `_retry` would queue `job` unless its object already satisfies the condition; whether there was one."""
        if not self.spares:
            return False
        spare = self.spares.popleft()
        self.compiled = [spare if compiled.obj == job.obj else compiled for compiled in self.compiled]
        if job_done(self.env, spare):
            return True
        if first:
            self.jobs.appendleft(spare)
        else:
            self.jobs.append(spare)
        return True

    # ------------------------------------------------------------------------------------------------ the skills
    def _plan_job(self, job: Job) -> None:
        """Queue the moves of `job` with the skill its object's situation calls for."""
        env, motion = self.env, self.motion
        if job.upright and job.onto is not None:  # a lying container stood up first where it can be, then moved
            if self._stand_up_first(job):
                self.job = None  # only the stand-up is queued: the move queued after it is the job checked
                return
            job = self.job = Job(job.obj, onto=job.onto, centred=job.centred)
        if job.upright:
            if upside_down(env, job.obj):  # first onto its side (then stood up by the job planned again)
                self._tip_first(job)
                return
            stand_upright(motion, job.obj)
            return
        where = {"onto": job.onto, "at": job.at}
        if not env.scene.gpu_sim_enabled and covered(env, job.obj):  # on a shelf level under another
            front_pick_and_place(motion, job.obj, centred=job.centred, lift=job.lift, **where)
            return
        if self._side_hold(job):  # a long tool in a bin, its handle out over the wall: held there from the side
            return
        board = leaning_board(env, job.obj) if job.at is not None and job.onto is None else None
        if board is not None:  # too wide for the fingers, leaning in a container: stood up, lifted out, laid down
            lift_out_standing(motion, job.obj, board, job.at)
            return
        after = self._sharing(job)
        failed = self.grasps.setdefault(job.obj, [])
        grasp = grasp_pose(env, job.obj, failed=failed)
        failed.append(grasp)  # a job that succeeds is not planned again, so only failed grasps are looked at
        pick_and_place(motion, job.obj, grasp, centred=job.centred, lift=job.lift, after=after, **where)

    def _stand_up_first(self, job: Job) -> bool:
        """Where `job`'s object is a container lying on its side (a top-down grasp lands the open fingers on its
        round body), queue the tip that stands it up and put the move itself back at the front of the jobs; False
        (nothing queued) where it no longer lies or the tip cannot be planned."""
        if not lying_container(self.env, job.obj):
            return False
        planned = self.motion.mark()
        try:
            stand_upright(self.motion, job.obj)
        except OracleFailure:
            self.motion.rewind(planned)
            return False
        self.jobs.appendleft(Job(job.obj, onto=job.onto, centred=job.centred))
        return True

    def _tip_first(self, job: Job) -> None:
        """Queue the push that tips `job`'s upside-down object onto its side and put the job back at the front of
        the jobs, to be planned again from where the object lies; OracleFailure once it has been pushed TIPS times."""
        used = self.tips.get(job.obj, 0)
        if used >= TIPS:
            raise OracleFailure(f"'{job.obj}' is still upside down after {used} pushes to tip it onto its side")
        self.tips[job.obj] = used + 1
        tip_onto_side(self.motion, job.obj)
        self.job = None  # only the push is queued: the job planned again is the one checked
        self.jobs.appendleft(job)

    def _side_hold(self, job: Job) -> bool:
        """Plan `job` (onto the table or into a container) with a side hold of its object's handle, where the object
        is a long tool in a container with its handle reaching out (`side_grips`); where both sides of it are taken,
        or no hold from its free side has a motion plan, the first later job whose object has a free side is planned
        instead and `job` goes to the back of the queue (packed tools are taken from the outside in, and a tool
        reached only from a side the arm cannot get to waits until its neighbour is gone). Where that job's hold
        cannot be planned either, it goes to the back of the queue, nothing is planned and the caller takes `job`'s
        object from above, as any object (a hold that fails half-way, reaching in and backing out, jostles the tools
        beside it: tried again and again, it props the tool it was waiting for up against the wall). Whether a job
        was planned; the next of the holds comes first each time the job is planned again."""
        env = self.env
        if job.at is None and job.onto is None:
            return False
        grips = side_grips(env, job.obj)
        if grips:
            try:
                self._hold_by_handle(job, grips)
                return True
            except OracleFailure:
                return self._hold_later_instead(job)  # else held from above, as any object
        if side_grips(env, job.obj, fits=True):  # walled in on both sides: first one that is not
            return self._hold_later_instead(job)
        return False

    def _hold_later_instead(self, job: Job) -> bool:
        """Plan the first later job whose object has a side hold in place of `job`, which goes to the back of the
        queue; False (nothing planned) where there is none or its hold has no motion plan, `later` then going to the
        back of the queue (the next try starts from another tool: the order of packed tools decides which holds can
        be planned)."""
        env = self.env
        later = next((other for other in self.jobs if side_grips(env, other.obj)), None)
        if later is None:
            return False
        self.jobs.remove(later)
        self.jobs.append(job)
        self.job = later
        try:
            self._hold_by_handle(later, side_grips(env, later.obj))
            return True
        except OracleFailure:  # `later` goes after the others, its retries unused; `job` is held from above
            self.jobs.remove(job)
            self.jobs.append(later)
            self.job = job
            return False

    def _hold_by_handle(self, job: Job, grips: list[tuple[np.ndarray, np.ndarray]]) -> None:
        tried = self.grasps.setdefault(job.obj, [])
        side_hold_pick_and_place(self.motion, job.obj, grips, tried, onto=job.onto, at=job.at)

    def _sharing(self, job: Job) -> list[str] | None:
        """Where the task's jobs set several objects onto `job`'s small flat top (`places.crowded_top`): the objects
        still to go onto it after this one; else None."""
        env = self.env
        if job.onto is None or job.centred or env.scene.gpu_sim_enabled:
            return None
        sharing = [other.obj for other in jobs_for(env) if other.onto == job.onto and not other.centred]
        if job.obj not in sharing or not crowded_top(env, job.onto, sharing):
            return None
        return [
            other.obj for other in self.jobs if other.onto == job.onto and not other.centred and other.obj != job.obj
        ]
