"""The oracle's closed loop over jobs (policies/oracle/policy.py), on whole episodes where it decides the outcome:
after a lift job's moves the hand holds still keeping its grip (the arm lags its commands, so the drill is still
rising when the moves run out), and once every job is done the jobs whose object was knocked out of place by a
later one are planned again."""

import json

import pytest

from robolab_ms.eval.runner import EvalConfig, run_evaluation
from robolab_ms.policies import make_policy


def _episode(tmp_path, task: str, seed: int):
    config = EvalConfig(tasks=(task,), episodes=1, first_seed=seed)
    results = run_evaluation(make_policy("oracle"), config, tmp_path, show_progress=False)
    episodes = [json.loads(line) for line in (tmp_path / "episodes.jsonl").read_text().splitlines()]
    return results[0], episodes[0]


def _scripted_plans(oracle, fails) -> list[str]:
    """Replace `oracle`'s planning: every job planned is recorded in the list returned; a job for which
    `fails(name, planned)` is true raises OracleFailure, the others queue one still step."""
    from robolab_ms.policies.oracle import OracleFailure

    planned = []

    def plan(job):
        planned.append(job.obj)
        if fails(job.obj, planned):
            raise OracleFailure("no motion plan")
        oracle.job = None
        oracle.motion.hold(oracle.motion.current_qpos(), 0.0, 1)

    oracle._plan_job = plan
    return planned


@pytest.fixture
def oracle_on():
    """`oracle_on(task)`: the task's environment reset at seed 0 and the oracle bound to it and reset; closed after
    the test."""
    from robolab_ms.envs import RoboLabEnv
    from robolab_ms.policies.oracle import OraclePolicy

    made = []

    def make(task: str):
        env = RoboLabEnv(task=task, obs_mode="state_dict", render_backend="cpu")
        made.append(env)
        env.reset(seed=0)
        oracle = OraclePolicy()
        oracle.bind(env)
        oracle.reset("", env.action_space, seed=0)
        return env, oracle

    yield make
    for env in made:
        env.close()


@pytest.mark.slow
def test_a_lifted_drill_is_held_while_the_arm_catches_up(tmp_path):
    """PickDrill seed 8: the moves of the lift end with the drill's lowest corner 3.0 cm up, not yet the 3 cm the
    condition needs with margin; opened then, the hand dropped it and the episode ran out of time."""
    result, episode = _episode(tmp_path, "PickDrill", 8)
    assert result.error is None and result.success
    assert not any(event["type"] == "target_dropped" for event in episode["events"])


@pytest.mark.slow
def test_a_ladle_knocked_out_of_the_pot_is_put_back(tmp_path):
    """GreenSpoonsInPot seed 4: the first ladle is in the pot when its job is checked, and the next one knocks it
    over; once the queue is empty its job is planned again and the ladle let go in the pot a second time (without
    that, the episode ran out of time)."""
    result, episode = _episode(tmp_path, "GreenSpoonsInPot", 4)
    assert result.error is None and result.success
    ladle = [event["type"] for event in episode["events"] if event["object"] == "ladle"]
    assert "object_tipped_over" in ladle and ladle.count("target_dropped") >= 2


def test_a_job_given_up_hands_over_to_a_spare_object(oracle_on):
    """PutTwoMugsOnShelf asks for any two of three mugs: once the second mug's job has failed on every retry, the
    oracle moves the third mug in its place (and looks over it, not the given-up one, at the end); a task that
    needs every one of its objects has no spare and the failure ends the episode."""
    from robolab_ms.policies.oracle import OracleFailure
    from robolab_ms.policies.oracle.policy import JOB_RETRIES

    env, oracle = oracle_on("PutTwoMugsOnShelf")
    assert [job.obj for job in oracle.compiled] == ["ceramic_mug", "mug"]
    planned = _scripted_plans(oracle, lambda name, planned: name == "mug")  # the white mug's job never plans
    oracle.act({})
    oracle.act({})
    assert planned == ["ceramic_mug"] + ["mug"] * (JOB_RETRIES + 1) + ["mug_01"]
    assert [job.obj for job in oracle.compiled] == ["ceramic_mug", "mug_01"]

    oracle.reset("", env.action_space, seed=0)
    oracle.spares.clear()  # as for a task that needs all of its objects
    planned.clear()
    oracle.act({})
    with pytest.raises(OracleFailure):
        oracle.act({})


def test_the_oracle_gives_up_once_every_retry_is_used_instead_of_running_out_the_time(oracle_on):
    """A job whose plan leaves its object where it was is planned again JOB_RETRIES times; once the object has lain
    still GIVE_UP_STEPS the job has its last try, and once it lies still that long again the oracle raises
    OracleFailure naming it, so a hopeless episode ends there rather than idling to its time limit."""
    from robolab_ms.policies.oracle import OracleFailure
    from robolab_ms.policies.oracle.policy import GIVE_UP_STEPS, JOB_RETRIES

    env, oracle = oracle_on("BananaInBowl")
    planned = _still_plans(oracle)
    with pytest.raises(OracleFailure, match="gave up on 'banana'"):
        _run(env, oracle, 1000)
    assert planned == ["banana"] * (JOB_RETRIES + 2)
    assert oracle._last_tried == {"banana"}
    assert 2 * GIVE_UP_STEPS <= int(env.elapsed_steps[0]) < 300


def test_an_object_that_never_comes_to_rest_has_its_last_try_after_a_bounded_wait(oracle_on, monkeypatch):
    """Retries used up, an object left out of place that keeps moving (a tool rocking on another one) is waited for
    GIVE_UP_WAIT_STEPS at most before its last try, and as long again before the oracle gives up."""
    from robolab_ms.policies.oracle import OracleFailure
    from robolab_ms.policies.oracle.policy import GIVE_UP_WAIT_STEPS, JOB_RETRIES

    env, oracle = oracle_on("BananaInBowl")
    planned = _still_plans(oracle)
    monkeypatch.setattr(oracle, "_lie_still", lambda names: False)
    with pytest.raises(OracleFailure, match="gave up on 'banana'"):
        _run(env, oracle, 2000)
    assert planned == ["banana"] * (JOB_RETRIES + 2)
    assert 2 * GIVE_UP_WAIT_STEPS <= int(env.elapsed_steps[0]) < 2 * GIVE_UP_WAIT_STEPS + 200


def _still_plans(oracle) -> list[str]:
    """Replace `oracle`'s planning by one still step that moves nothing; the jobs planned go to the list returned."""
    planned = []

    def plan(job):
        planned.append(job.obj)
        oracle.motion.hold(oracle.motion.current_qpos(), 0.0, 1)

    oracle._plan_job = plan
    return planned


def _run(env, oracle, limit: int) -> None:
    """Step `env` with `oracle`'s actions until it has run `limit` steps of its episode."""
    while int(env.elapsed_steps[0]) < limit:
        env.step(oracle.act({}))


def test_the_oracle_waits_for_an_object_still_moving_before_it_gives_up(tmp_path):
    """TakeMeasuringSpoonOut seed 4: the measuring cup's last retry leaves it still moving, and it comes to rest where
    the condition wants it 36 steps after the oracle's last move (a fixed wait of 30 steps gave up 5 steps early)."""
    result, episode = _episode(tmp_path, "TakeMeasuringSpoonOut", 4)
    assert result.error is None and result.success


def test_a_job_that_cannot_be_planned_waits_for_the_others_without_using_a_retry(oracle_on):
    """A job whose plan fails goes after the others once and keeps its retries while another job can still be
    planned (moving that one may free its way: a hammer reached only from the side of a neighbour still in the bin);
    once every job queued has failed to plan since the last plan that worked, failures use up retries again."""
    from robolab_ms.policies.oracle import OracleFailure

    env, oracle = oracle_on("AppleAndYogurtInBowl")
    first, second = (job.obj for job in oracle.compiled)
    planned = _scripted_plans(oracle, lambda name, planned: name == first and second not in planned)
    oracle.act({})
    oracle.act({})
    assert planned == [first, second, first]
    assert oracle.retries == {}

    oracle.reset("", env.action_space, seed=0)
    planned = _scripted_plans(oracle, lambda name, planned: True)
    with pytest.raises(OracleFailure):
        oracle.act({})
    assert planned[:2] == [first, second]  # each waits once for the other, then the retries are used up
    assert oracle.retries == {first: 2, second: 2}


def test_a_plan_given_up_half_way_leaves_the_gripper_command_as_it_was(oracle_on):
    """`rewind` drops the actions of a plan given up after its grasp closed the hand, and the closed command with
    them: the next plan starts with the hand open (it had closed on nothing at the start of the episode)."""
    env, oracle = oracle_on("BananaInBowl")
    motion = oracle.motion
    planned = motion.mark()
    motion.hold(motion.current_qpos(), 1.0, 3)
    assert motion.gripper == 1.0 and len(motion.actions) == 3
    motion.rewind(planned)
    assert motion.gripper == 0.0 and len(motion.actions) == 0
    motion.hold(motion.current_qpos(), motion.gripper, 1)
    assert motion.actions[0][7] == 0.0


def test_a_tool_without_a_side_hold_that_can_be_planned_is_taken_from_above(monkeypatch):
    """Where neither the job's tool nor the first later tool has a side hold with a motion plan, `_side_hold` plans
    nothing, so the job is planned with a grasp from above (a hold that fails half-way jostles the tools beside it),
    and that later tool goes after the others (the next try starts from another one); where a later tool's hold can
    be planned, that one goes first and the job goes to the back."""
    from collections import deque

    import numpy as np

    from robolab_ms.policies.oracle import OracleFailure, OraclePolicy
    from robolab_ms.policies.oracle import policy as oracle_policy
    from robolab_ms.policies.oracle.compile import Job

    holdable: set[str] = set()
    held: list[str] = []

    def hold(motion, name, grips, tried, onto=None, at=None):
        if name not in holdable:
            raise OracleFailure(f"cannot hold '{name}' by its handle from the side")
        held.append(name)

    monkeypatch.setattr(oracle_policy, "side_grips", lambda env, name, fits=False: [(np.zeros(7), np.zeros(3))])
    monkeypatch.setattr(oracle_policy, "side_hold_pick_and_place", hold)
    oracle = OraclePolicy()
    jobs = [Job(name, at=(0.3, 0.0)) for name in ("wood", "red", "blue")]

    oracle.jobs, oracle.grasps, oracle.job = deque(jobs[1:]), {}, jobs[0]
    assert oracle._side_hold(jobs[0]) is False
    assert list(oracle.jobs) == [jobs[2], jobs[1]] and oracle.job == jobs[0] and held == []

    oracle.jobs = deque(jobs[1:])
    holdable.add("red")
    assert oracle._side_hold(jobs[0]) is True
    assert held == ["red"] and oracle.job == jobs[1] and list(oracle.jobs) == [jobs[2], jobs[0]]
