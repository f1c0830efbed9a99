"""Trajectory metrics (RoboLab's definitions) against values worked out by hand or published, event tallies, the
result and summary columns they feed (older result lines included), adaptive sampling's stopping rule and task
selection."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from robolab_ms.analysis.tables import episode_frame, success_interval, summarize, summary_markdown
from robolab_ms.eval.metrics import (
    METRIC_KEYS,
    event_tallies,
    integrated_squared_jerk,
    path_length,
    sparc,
    sparc_reference,
    trajectory_metrics,
)
from robolab_ms.eval.results import EPISODES_FILE, EpisodeResult, append_result, read_results
from robolab_ms.eval.runner import adaptive_sampling_done

RATE = 15.0
DT = 1.0 / RATE


def minimum_jerk_speed(duration: float, rate: float, amplitude: float = 1.0) -> np.ndarray:
    """Speed of a minimum-jerk reach of `amplitude` over `duration` s, sampled at `rate` Hz (ends included)."""
    tau = np.arange(0.0, duration + 1e-9, 1.0 / rate) / duration
    return amplitude * 30.0 * tau**2 * (1.0 - tau) ** 2 / duration


def continuous_sparc(speed_of_tau, threshold: float = 0.05) -> float:
    """SPARC of a speed profile on [0, 1] from its Fourier integral evaluated directly (no FFT, no padding)."""
    tau = np.linspace(0.0, 1.0, 501)  # at most 4 periods over [0, 1]: the trapezoid rule is exact enough
    profile = speed_of_tau(tau)
    frequency = np.linspace(0.0, 4.0, 4001)  # the magnitude of this profile stays below 0.05 beyond 2 Hz
    magnitude = np.abs(np.trapz(profile * np.exp(-2j * np.pi * frequency[:, None] * tau), tau, axis=1))
    magnitude /= magnitude[0]
    last = np.flatnonzero(magnitude >= threshold)[-1]
    f, m = frequency[: last + 1] / frequency[last], magnitude[: last + 1]
    return -float(np.sum(np.hypot(np.diff(f), np.diff(m))))


def arc(frequency: np.ndarray, magnitude: np.ndarray, cutoff: float) -> float:
    """Minus the arc length of a spectrum, frequency divided by the cutoff (the definition, written out)."""
    return -float(
        sum(
            math.sqrt(((f1 - f0) / cutoff) ** 2 + (m1 - m0) ** 2)
            for f0, f1, m0, m1 in zip(frequency, frequency[1:], magnitude, magnitude[1:])
        )
    )


def test_sparc_of_two_equal_samples_from_the_closed_form_spectrum():
    # [1, 1] padded to 2 x 4 = 8 points: |X(k)| = 2 |cos(pi k / 8)|, k = 0..4, at k x 15/8 Hz; normalised 1,
    # cos(pi/8), cos(pi/4), cos(3 pi/8), 0. The highest bin at or above 0.05 is k = 3 (5.625 Hz): the cutoff.
    magnitude = [1.0, math.cos(math.pi / 8), math.cos(math.pi / 4), math.cos(3 * math.pi / 8)]
    expected = arc([0.0, 1.875, 3.75, 5.625], magnitude, 5.625)
    assert sparc([1.0, 1.0], DT) == pytest.approx(expected, abs=1e-12)
    assert sparc([0.3, 0.3], DT) == pytest.approx(expected, abs=1e-12)  # the scale does not matter
    # padded to 2 x 2**4 = 32 points instead (the SPARC paper's padding) the value is another one
    assert abs(sparc_reference([1.0, 1.0], DT) - expected) > 0.05


def test_sparc_of_a_constant_speed_from_the_dirichlet_kernel():
    # 8 equal samples padded to 8 x 4 = 32 points: |X(k)| / X(0) = |sin(pi k / 4)| / (8 |sin(pi k / 32)|)
    k = np.arange(17)  # one-sided: 0 Hz up to the Nyquist frequency, 7.5 Hz
    with np.errstate(divide="ignore", invalid="ignore"):
        magnitude = np.where(k == 0, 1.0, np.abs(np.sin(np.pi * k / 4)) / (8 * np.abs(np.sin(np.pi * k / 32))))
    frequency = k * RATE / 32
    last = int(np.flatnonzero(magnitude >= 0.05)[-1])
    expected = arc(frequency[: last + 1], magnitude[: last + 1], frequency[last])
    assert sparc(np.full(8, 0.2), DT) == pytest.approx(expected, abs=1e-12)


def test_sparc_cutoff_is_capped_at_10_hz_and_one_kept_point_gives_zero():
    # at 100 Hz, [1, 1] padded to 8 points has bins every 12.5 Hz: only 0 Hz lies under the 10 Hz cap
    assert sparc([1.0, 1.0], 0.01) == 0.0
    # with 4 samples at 100 Hz (16 bins, 6.25 Hz apart) the cap keeps 0 and 6.25 Hz: cutoff 10 Hz, not 6.25
    magnitude = [1.0, abs(1 + np.exp(-2j * np.pi / 16) + np.exp(-4j * np.pi / 16) + np.exp(-6j * np.pi / 16)) / 4]
    assert sparc(np.ones(4), 0.01) == pytest.approx(arc([0.0, 6.25], magnitude, 10.0), abs=1e-12)


def test_sparc_matches_the_published_check_value_only_in_the_reference_variant():
    # the value the reference implementation of Balasubramanian et al. gives for exp(-5 t^2), t in [-1, 1), 100 Hz
    t = np.arange(-1.0, 1.0, 0.01)
    assert sparc_reference(np.exp(-5.0 * t**2), 0.01) == pytest.approx(-1.41403, abs=1e-5)
    assert sparc(np.exp(-5.0 * t**2), 0.01) == pytest.approx(-1.39978, abs=1e-5)  # RoboLab's: padding x 4


def test_sparc_of_a_minimum_jerk_reach_is_near_its_fourier_integral():
    expected = continuous_sparc(lambda tau: 30.0 * tau**2 * (1.0 - tau) ** 2)
    assert expected == pytest.approx(-1.41, abs=0.01)
    for duration, amplitude in ((1.0, 0.3), (2.0, 1.0), (4.0, 0.05)):
        assert sparc(minimum_jerk_speed(duration, RATE, amplitude), DT) == pytest.approx(expected, abs=0.03)


def test_sparc_is_lower_for_a_noisy_or_segmented_reach():
    smooth = sparc(minimum_jerk_speed(2.0, RATE), DT)
    rng = np.random.default_rng(0)
    speed = minimum_jerk_speed(2.0, RATE)
    noisy = np.abs(speed + rng.normal(0.0, 0.1 * speed.max(), speed.size))
    two_moves = np.concatenate([minimum_jerk_speed(1.0, RATE), minimum_jerk_speed(1.0, RATE)[1:]])
    assert sparc(noisy, DT) < smooth - 0.1
    assert sparc(two_moves, DT) < smooth - 0.3


def test_sparc_of_a_motionless_or_too_short_profile_is_nan():
    for profile in (np.zeros(60), np.full(60, 1e-8), [], [0.4]):
        assert math.isnan(sparc(profile, DT)) and math.isnan(sparc_reference(profile, DT))


def test_path_length_of_a_polyline_and_a_circle():
    assert path_length(np.array([[0, 0, 0], [3, 4, 0], [3, 4, 2]], dtype=float)) == pytest.approx(7.0)
    angle = np.linspace(0.0, 2 * np.pi, 2001)
    circle = np.stack([0.2 * np.cos(angle), 0.2 * np.sin(angle), np.zeros_like(angle)], axis=1)
    assert path_length(circle) == pytest.approx(2 * np.pi * 0.2, rel=1e-5)


def test_integrated_squared_jerk_of_small_paths_worked_by_hand():
    # velocity 0, 0, 1, 0, 0 (dt = 1): acceleration (gradient) 0, 1/2, 0, -1/2, 0; jerk 1/2, 0, -1/2, 0, 1/2;
    # squared 1/4, 0, 1/4, 0, 1/4; trapezoid 3/4 - (1/4 + 1/4) / 2 = 1/2. With dt: jerk / dt^2, so ISJ / dt^3.
    pulse = np.array([0.0, 0.0, 1.0, 0.0, 0.0])
    assert integrated_squared_jerk(pulse, 1.0) == pytest.approx(0.5, abs=1e-12)
    assert integrated_squared_jerk(pulse, 0.5) == pytest.approx(0.5 / 0.5**3, abs=1e-12)
    # a step 0, 0, 0, 1, 1, 1 in position (dt = 1): velocity 0, 0, 1/2, 1/2, 0, 0; acceleration 0, 1/4, 1/4,
    # -1/4, -1/4, 0; jerk 1/4, 1/8, -1/4, -1/4, 1/8, 1/4; trapezoid of the squares 9/32 - 1/16 = 7/32, / dt^5
    step = np.array([0, 0, 0, 1, 1, 1], dtype=float)
    path = np.outer(step, [0.6, 0.8, 0.0])  # the same step along a unit direction: same jerk norm
    metrics = trajectory_metrics(path, np.zeros((6, 7)), np.zeros((5, 7)), 0.5)
    assert metrics["ee_isj"] == pytest.approx(7 / 32 / 0.5**5, abs=1e-9)
    # velocity linear in time: every gradient is exact, the acceleration constant, no jerk at all
    assert integrated_squared_jerk(np.outer(np.arange(10.0), [1.0, -2.0]), DT) == pytest.approx(0.0, abs=1e-9)


def test_end_effector_speed_is_the_gradient_of_the_positions():
    # 0, 0, 0, 1 along (0.6, 0.8, 0), dt = 0.5: np.gradient gives 0, 0, 1, 2 (central inside, one-sided at the
    # ends): mean 0.75, max 2; forward differences would give 0, 0, 2 (mean 0.667)
    path = np.outer([0.0, 0.0, 0.0, 1.0], [0.6, 0.8, 0.0])
    metrics = trajectory_metrics(path, np.zeros((4, 7)), np.zeros((3, 7)), 0.5)
    assert metrics["ee_speed_mean"] == pytest.approx(0.75) and metrics["ee_speed_max"] == pytest.approx(2.0)
    assert metrics["ee_path_length"] == pytest.approx(1.0)


def test_trajectory_metrics_of_a_constant_velocity_path():
    steps, velocity = 24, np.array([0.03, -0.04, 0.0])  # 5 cm/s
    path = np.array([0.4, 0.1, 0.3]) + np.outer(np.arange(steps + 1) * DT, velocity)
    joints = np.outer(np.arange(steps + 1) * DT, np.linspace(0.1, 0.7, 7))  # each joint at its constant speed
    metrics = trajectory_metrics(path, joints, joints[1:], DT)
    assert metrics["ee_speed_mean"] == pytest.approx(0.05) and metrics["ee_speed_max"] == pytest.approx(0.05)
    assert metrics["ee_path_length"] == pytest.approx(0.05 * steps * DT)
    assert metrics["ee_isj"] == pytest.approx(0.0, abs=1e-9) and metrics["joint_isj"] == pytest.approx(0.0, abs=1e-9)
    constant = sparc(np.ones(steps + 1), DT)  # SPARC does not depend on the speed's scale
    assert metrics["ee_sparc"] == pytest.approx(constant) and metrics["joint_sparc_mean"] == pytest.approx(constant)
    assert metrics["joint_rmse_mean"] == 0.0 and metrics["joint_tracking_max"] == 0.0


def test_joint_rmse_is_the_mean_over_joints_of_each_joints_rms():
    joints = np.zeros((5, 7))
    offsets = np.arange(1, 8) * 0.01  # joint j always misses its target by 0.01 (j + 1) rad
    signs = np.array([1, -1, 1, -1])[:, None]  # the sign of the miss alternates: the RMS is the size
    metrics = trajectory_metrics(np.zeros((5, 3)), joints, joints[1:] + signs * offsets, DT)
    assert metrics["joint_rmse_mean"] == pytest.approx(0.04)  # not the RMS over all joints (0.0447)
    assert metrics["joint_tracking_max"] == pytest.approx(0.07)


def test_joint_metrics_use_the_measured_velocities_and_leave_a_motionless_joint_out():
    positions = np.zeros((31, 7))  # the positions say nothing moved ...
    velocity = np.zeros((31, 7))
    velocity[:, 0] = minimum_jerk_speed(2.0, RATE)  # ... the measured velocities say joint 0 moved
    velocity[:, 1] = -2 * minimum_jerk_speed(2.0, RATE)
    metrics = trajectory_metrics(np.zeros((31, 3)), positions, np.zeros((30, 7)), DT, joint_velocities=velocity)
    assert metrics["joint_sparc_mean"] == pytest.approx(sparc(minimum_jerk_speed(2.0, RATE), DT))
    assert metrics["joint_isj"] == pytest.approx(5 * integrated_squared_jerk(velocity[:, 0], DT))
    assert math.isnan(metrics["ee_sparc"])  # the gripper did not move


def test_trajectory_metrics_need_three_samples_and_motion():
    short = trajectory_metrics(np.array([[0.0, 0, 0], [0.1, 0, 0]]), np.zeros((2, 7)), np.zeros((1, 7)), DT)
    assert set(short) == set(METRIC_KEYS) and all(math.isnan(value) for value in short.values())
    still = trajectory_metrics(
        np.tile([0.4, 0.0, 0.3], (20, 1)),
        np.tile(np.linspace(-1, 1, 7), (20, 1)),
        np.tile(np.linspace(-1, 1, 7), (19, 1)),
        DT,
    )
    assert math.isnan(still["ee_sparc"]) and math.isnan(still["joint_sparc_mean"])
    assert still["ee_path_length"] == 0.0 and still["ee_speed_max"] == 0.0 and still["ee_isj"] == 0.0


def test_event_tallies_count_types_and_name_objects():
    events = [
        {"step": 3, "type": "wrong_object_grasped", "object": "apple"},
        {"step": 9, "type": "gripper_hit_table", "object": "table"},
        {"step": 12, "type": "wrong_object_grasped", "object": "soup_can"},
        {"step": 20, "type": "wrong_object_grasped", "object": "apple"},
        {"step": 25, "type": "object_bumped", "object": "bowl"},
    ]
    counts, objects = event_tallies(events)
    assert counts == {"gripper_hit_table": 1, "object_bumped": 1, "wrong_object_grasped": 3}
    assert objects == {"object_bumped": ["bowl"], "wrong_object_grasped": ["apple", "soup_can"]}


OLD_LINE = {  # a result line written before metrics and tallies existed
    "task": "BananaInBowl", "instruction_variant": "default", "instruction": "Put the banana in the bowl.",
    "robot": "droid", "policy": "random", "seed": 0, "success": False, "score": 0.0, "progress": 0.0, "steps": 5,
    "max_steps": 5, "success_step": None, "wall_seconds": 1.0, "error": None, "metrics": {}, "version": 1,
    "events": [{"step": 2, "type": "gripper_fully_closed", "object": "gripper"},
               {"step": 4, "type": "object_bumped", "object": "apple"}],
}  # fmt: skip


def result(seed: int, success: bool, sparc_value: float | None, bumps: int) -> EpisodeResult:
    events = [{"step": i + 1, "type": "object_bumped", "object": "apple"} for i in range(bumps)]
    counts, objects = event_tallies(events)
    return EpisodeResult(
        task="BananaInBowl",
        instruction_variant="default",
        instruction="x",
        robot="droid",
        policy="random",
        seed=seed,
        success=success,
        score=float(success),
        progress=float(success),
        steps=5,
        max_steps=5,
        success_step=None,
        wall_seconds=1.0,
        events=events,
        metrics={"ee_sparc": sparc_value, "ee_speed_mean": 0.05},
        event_counts=counts,
        event_objects=objects,
    )


def test_old_result_lines_still_load_and_summarise(tmp_path):
    (tmp_path / EPISODES_FILE).write_text(json.dumps(OLD_LINE) + "\n", encoding="utf-8")
    append_result(tmp_path, result(1, True, -1.5, 2))
    loaded = read_results(tmp_path)
    assert [r.seed for r in loaded] == [0, 1]
    assert loaded[0].event_counts == {} and loaded[0].recording is None and loaded[0].video is None
    frame = episode_frame(loaded)
    assert frame["object_bumped"].tolist() == [1, 2]  # older lines: tallied from the ordered event list
    assert frame["gripper_fully_closed"].tolist() == [1, 0]
    assert math.isnan(frame["ee_sparc"][0]) and frame["ee_sparc"][1] == -1.5


VERSION_1_LINE = {  # a result line of results version 1: metrics under their old names and definitions
    **OLD_LINE, "seed": 3, "metrics": {"ee_sparc": -4.2, "joint_sparc": -3.0, "ee_jerk": 12.0, "joint_jerk": 30.0,
                                       "ee_path_length": 0.8, "ee_speed_mean": 0.1, "ee_speed_max": 0.3,
                                       "joint_tracking_rmse": 0.02, "joint_tracking_max": 0.05},
}  # fmt: skip


def test_version_1_metrics_load_as_the_old_variant_and_never_mix_with_robolabs(tmp_path):
    (tmp_path / EPISODES_FILE).write_text(json.dumps(VERSION_1_LINE) + "\n", encoding="utf-8")
    append_result(tmp_path, result(1, True, -1.5, 0))  # a line of this version
    old, new = sorted(read_results(tmp_path), key=lambda r: r.seed, reverse=True)
    assert old.version == 1 and new.version == 2
    assert old.metrics == {
        "ee_sparc_v1": -4.2,
        "joint_sparc_v1": -3.0,
        "ee_jerk_v1": 12.0,
        "joint_jerk_v1": 30.0,
        "ee_path_length_v1": 0.8,
        "ee_speed_mean_v1": 0.1,
        "ee_speed_max_v1": 0.3,
        "joint_tracking_rmse_v1": 0.02,
        "joint_tracking_max": 0.05,
    }
    table = summarize([old, new])
    row = table[table["task"] == "BananaInBowl"].iloc[0]
    assert row["ee_sparc"] == -1.5 and row["ee_sparc_v1"] == -4.2  # each from its own episode
    assert row["ee_path_v1_cm"] == pytest.approx(80.0) and row["joint_tracking_max_rad"] == 0.05
    assert "ee_sparc_v1" in summary_markdown(table)
    assert "ee_sparc_v1" not in episode_frame([new])  # the old columns only where old lines are read


def test_summary_has_metric_and_event_means_with_spread():
    results = [result(0, True, -1.5, 0), result(1, False, -2.5, 2), result(2, False, None, 4)]
    table = summarize(results)
    row = table[table["task"] == "BananaInBowl"].iloc[0]
    assert row["ee_sparc"] == pytest.approx(-2.0)  # the undefined SPARC is left out
    assert row["ee_sparc_sd"] == pytest.approx(np.std([-1.5, -2.5], ddof=1))
    assert row["ee_speed_mean_cm_s"] == pytest.approx(5.0)
    assert row["object_bumped"] == pytest.approx(2.0)
    assert row["object_bumped_sd"] == pytest.approx(2.0)
    assert row["wrong_object_grasped"] == 0.0
    markdown = summary_markdown(table)
    assert "-2.000 ± 0.707" in markdown and "2.00 ± 2.00" in markdown
    assert "wrong_object_grasped" not in markdown  # event types that never fired are not shown


def test_adaptive_sampling_stops_at_the_interval_width_at_least_ten_and_at_most_max():
    assert not adaptive_sampling_done(0, 9, 400, 0.9)  # never before 10 episodes
    assert adaptive_sampling_done(0, 10, 400, 0.30)  # 0/10: [0.2 %, 28.5 %], narrower than 0.30
    assert adaptive_sampling_done(5, 11, 11, 0.01)  # the maximum ends it whatever the width
    for successes_rate in (0.0, 0.3, 0.5):
        stop = next(n for n in range(1, 500) if adaptive_sampling_done(round(successes_rate * n), n, 1000, 0.14))
        low, high = success_interval(round(successes_rate * stop), stop)
        assert high - low <= 0.14 and stop >= 10
        low, high = success_interval(round(successes_rate * (stop - 1)), stop - 1)
        assert stop == 10 or high - low > 0.14


def test_task_filters_select_by_tag_axis_difficulty_and_scene():
    from robolab_ms.errors import UnknownNameError
    from robolab_ms.tasks.selection import filter_tasks
    from robolab_ms.tasks.spec import load_all_tasks

    specs = load_all_tasks()
    names = lambda chosen: {spec.name for spec in chosen}  # noqa: E731
    assert names(filter_tasks(specs, tags=["spatial"])) == {s.name for s in specs if "spatial" in s.attributes}
    assert names(filter_tasks(specs, tags=["procedural"])) == {
        s.name for s in specs if {"affordance", "reorientation", "stacking", "sorting"} & set(s.attributes)
    }
    complex_spatial = filter_tasks(specs, tags=["spatial", "stacking"], difficulties=["complex"])
    assert names(complex_spatial) == {
        s.name for s in specs if s.difficulty == "complex" and {"spatial", "stacking"} & set(s.attributes)
    }
    assert names(filter_tasks(specs, scenes=["colored_blocks"])) == {
        "BlockStackingOrderAgnostic",
        "BlockStackingSpecifiedOrder",
    }
    assert "BlockStackingSpecifiedOrder" in names(filter_tasks(specs, tags=["stacking"]))
    with pytest.raises(UnknownNameError, match="spatial"):
        filter_tasks(specs, tags=["spatail"])
    with pytest.raises(UnknownNameError, match="complex"):
        filter_tasks(specs, difficulties=["hard"])
