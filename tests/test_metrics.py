"""Trajectory metrics against values known analytically or published, event tallies, the result and summary
columns they feed, adaptive sampling's stopping rule and task selection."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from robolab_ms.analysis.tables import episode_frame, success_interval, summarize, summary_markdown
from robolab_ms.eval.metrics import (
    event_tallies,
    integrated_squared_jerk,
    path_length,
    sparc,
    trajectory_metrics,
)
from robolab_ms.eval.results import EPISODES_FILE, EpisodeResult, append_result, read_results
from robolab_ms.eval.runner import adaptive_sampling_done

RATE = 15.0


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


def test_sparc_matches_the_published_check_value_of_a_gaussian_profile():
    # the value the reference implementation of Balasubramanian et al. gives for exp(-5 t^2), t in [-1, 1), 100 Hz
    t = np.arange(-1.0, 1.0, 0.01)
    assert sparc(np.exp(-5.0 * t**2), 100.0) == pytest.approx(-1.41403, abs=1e-5)


def test_sparc_of_a_minimum_jerk_reach_matches_its_fourier_integral_at_any_duration_and_amplitude():
    expected = continuous_sparc(lambda tau: 30.0 * tau**2 * (1.0 - tau) ** 2)
    assert expected == pytest.approx(-1.41, abs=0.01)
    for duration, amplitude in ((1.0, 0.3), (2.0, 1.0), (4.0, 0.05)):
        assert sparc(minimum_jerk_speed(duration, RATE, amplitude), RATE) == pytest.approx(expected, abs=0.02)
    # resting before and after the reach changes nothing
    padded = np.concatenate([np.zeros(20), minimum_jerk_speed(2.0, RATE), np.zeros(30)])
    assert sparc(padded, RATE) == pytest.approx(expected, abs=0.02)


def test_sparc_is_lower_for_a_noisy_or_segmented_reach():
    smooth = sparc(minimum_jerk_speed(2.0, RATE), RATE)
    rng = np.random.default_rng(0)
    speed = minimum_jerk_speed(2.0, RATE)
    noisy = np.abs(speed + rng.normal(0.0, 0.1 * speed.max(), speed.size))
    two_moves = np.concatenate([minimum_jerk_speed(1.0, RATE), minimum_jerk_speed(1.0, RATE)[1:]])
    assert sparc(noisy, RATE) < smooth - 0.1
    assert sparc(two_moves, RATE) < smooth - 0.3


def test_sparc_of_a_motionless_profile_is_nan():
    assert math.isnan(sparc(np.zeros(60), RATE))
    assert math.isnan(sparc(np.full(60, 1e-8), RATE))
    assert math.isnan(sparc([], RATE))


def test_path_length_of_a_polyline_and_a_circle():
    assert path_length(np.array([[0, 0, 0], [3, 4, 0], [3, 4, 2]], dtype=float)) == pytest.approx(7.0)
    angle = np.linspace(0.0, 2 * np.pi, 2001)
    circle = np.stack([0.2 * np.cos(angle), 0.2 * np.sin(angle), np.zeros_like(angle)], axis=1)
    assert path_length(circle) == pytest.approx(2 * np.pi * 0.2, rel=1e-5)


def test_integrated_squared_jerk_of_polynomial_paths():
    t = np.arange(0.0, 2.0 + 1e-9, 1.0 / RATE)
    jerk = 0.7  # x = jerk t^3 / 6 has constant jerk; finite differences of a cubic are exact
    cubic = np.stack([jerk * t**3 / 6.0, np.zeros_like(t), np.zeros_like(t)], axis=1)
    assert integrated_squared_jerk(cubic, RATE) == pytest.approx(jerk**2 * (len(t) - 3) / RATE, rel=1e-6)
    parabola = np.stack([t, 3 * t**2, -t], axis=1)  # no third derivative
    assert integrated_squared_jerk(parabola, RATE) == pytest.approx(0.0, abs=1e-6)
    assert math.isnan(integrated_squared_jerk(cubic[:3], RATE))


def test_trajectory_metrics_of_a_straight_minimum_jerk_reach():
    steps = 30
    tau = np.linspace(0.0, 1.0, steps + 1)
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5  # minimum-jerk position, 0 -> 1
    ee = np.stack([0.4 + 0.3 * s, np.zeros_like(s), 0.2 + 0.4 * s], axis=1)  # 0.5 m along a line
    joints = np.outer(s, np.linspace(0.1, 0.7, 7))
    targets = joints[1:] + 0.01  # every commanded target 0.01 rad beyond what was reached
    metrics = trajectory_metrics(ee, joints, targets, RATE)
    assert metrics["ee_path_length"] == pytest.approx(0.5, rel=1e-9)
    assert metrics["ee_speed_mean"] == pytest.approx(0.5 / (steps / RATE), rel=1e-9)
    assert metrics["ee_speed_max"] == pytest.approx(0.5 * 1.875 * RATE / steps, rel=0.02)  # peak 15/8 of the mean
    assert metrics["joint_tracking_rmse"] == pytest.approx(0.01, rel=1e-9)
    assert metrics["joint_tracking_max"] == pytest.approx(0.01, rel=1e-9)
    assert -1.6 < metrics["ee_sparc"] < -1.3
    assert -1.6 < metrics["joint_sparc"] < -1.3
    assert metrics["ee_jerk"] > 0 and metrics["joint_jerk"] > 0


def test_trajectory_metrics_of_a_robot_that_never_moves():
    ee = np.tile([0.4, 0.0, 0.3], (20, 1))
    joints = np.tile(np.linspace(-1, 1, 7), (20, 1))
    metrics = trajectory_metrics(ee, joints, joints[1:], RATE)
    assert math.isnan(metrics["ee_sparc"]) and math.isnan(metrics["joint_sparc"])
    assert metrics["ee_path_length"] == 0.0 and metrics["ee_speed_max"] == 0.0
    assert metrics["ee_jerk"] == 0.0 and metrics["joint_tracking_rmse"] == 0.0


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
    return EpisodeResult(task="BananaInBowl", instruction_variant="default", instruction="x", robot="droid",
                         policy="random", seed=seed, success=success, score=float(success), progress=float(success),
                         steps=5, max_steps=5, success_step=None, wall_seconds=1.0, events=events,
                         metrics={"ee_sparc": sparc_value, "ee_speed_mean": 0.05}, event_counts=counts,
                         event_objects=objects)  # fmt: skip


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
        stop = next(n for n in range(1, 500)
                    if adaptive_sampling_done(round(successes_rate * n), n, 1000, 0.14))  # fmt: skip
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
        s.name for s in specs if {"affordance", "reorientation", "stacking", "sorting"} & set(s.attributes)}
    complex_spatial = filter_tasks(specs, tags=["spatial", "stacking"], difficulties=["complex"])
    assert names(complex_spatial) == {s.name for s in specs if s.difficulty == "complex"
                                      and {"spatial", "stacking"} & set(s.attributes)}  # fmt: skip
    assert names(filter_tasks(specs, scenes=["colored_blocks"])) == {
        "BlockStackingOrderAgnostic", "BlockStackingSpecifiedOrder"}
    assert "BlockStackingSpecifiedOrder" in names(filter_tasks(specs, tags=["stacking"]))
    with pytest.raises(UnknownNameError, match="spatial"):
        filter_tasks(specs, tags=["spatail"])
    with pytest.raises(UnknownNameError, match="complex"):
        filter_tasks(specs, difficulties=["hard"])
