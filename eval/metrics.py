"""Per-episode trajectory metrics and event tallies, computed from what the recorder saw at the control rate.

Trajectory metrics, RoboLab's definitions (docs/results.md states them in full); the first eight carry RoboLab's
names and mean what RoboLab's result files mean by them:

| key | what | unit |
|---|---|---|
| `ee_sparc` | SPARC (`sparc`) of the gripper base link's speed (closer to 0 = smoother; NaN when it did not move) | - |
| `joint_sparc_mean` | mean over the arm joints of the SPARC of each joint's absolute velocity | - |
| `ee_isj` | integrated squared jerk of the gripper base link (`integrated_squared_jerk`) | m^2/s^5 |
| `joint_isj` | integrated squared jerk of the arm joint vector | rad^2/s^5 |
| `ee_path_length` | path length of the gripper base link (sum of segment lengths) | m |
| `ee_speed_max`, `ee_speed_mean` | largest and mean speed of the gripper base link | m/s |
| `joint_rmse_mean` | per arm joint the RMS of commanded target minus reached position, then the mean over joints | rad |
| `joint_tracking_max` | (ours) largest absolute commanded-minus-reached joint error | rad |

Velocities of the base link are `np.gradient` of its positions over dt; joint velocities are the simulator's.
With fewer than `MIN_SAMPLES` samples no metric is computed (all NaN); tables leave NaN out of their means.
Result lines written before these definitions (results version 1) hold other variants; `LEGACY_METRIC_NAMES`
says under which names they load. `sparc_reference` is the SPARC paper's own variant, for comparison only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

SPARC_CUTOFF_HZ = 10.0  # the highest frequency SPARC may look at
SPARC_AMPLITUDE_THRESHOLD = 0.05  # the adaptive cutoff: the highest frequency whose normalised magnitude reaches this
SPARC_PAD_FACTOR = 4  # RoboLab: FFT length = (next power of two >= samples) x 4
SPARC_REFERENCE_PAD_LEVEL = 4  # the SPARC paper's reference: FFT length = (next power of two) x 2**4
MOTIONLESS_SPEED = 1e-6  # a speed profile whose largest magnitude stays below this (unit/s) has no SPARC
MIN_SAMPLES = 3  # fewer samples than this: no metric is computed

ROBOLAB_METRIC_KEYS = (
    "ee_sparc", "joint_sparc_mean", "ee_isj", "joint_isj", "ee_path_length", "ee_speed_max", "ee_speed_mean",
    "joint_rmse_mean",
)  # fmt: skip
METRIC_KEYS = (*ROBOLAB_METRIC_KEYS, "joint_tracking_max")
# results version 1 (before RoboLab's definitions): its metric name -> the name its value loads under. Those were
# taken between the finger pads with forward differences, SPARC padded to (next power of two) x 2**4 and cut at the
# Nyquist frequency, jerk from third forward differences summed over steps, tracking RMS over all joints at once.
# `joint_tracking_max` meant then what it means now and keeps its name.
LEGACY_METRIC_NAMES = {
    name: f"{name}_v1"
    for name in (
        "ee_sparc",
        "joint_sparc",
        "ee_jerk",
        "joint_jerk",
        "ee_path_length",
        "ee_speed_mean",
        "ee_speed_max",
        "joint_tracking_rmse",
    )
}


def _next_power_of_two(count: int) -> int:
    """The smallest power of two >= count (count >= 1)."""
    return 1 << (int(count) - 1).bit_length()


def _speed_profile(speed: Sequence[float] | np.ndarray) -> np.ndarray | None:
    """The profile as float64, or None when SPARC is undefined for it (under 2 samples, non-finite, motionless)."""
    profile = np.asarray(speed, dtype=np.float64).ravel()
    if profile.size < 2 or not np.all(np.isfinite(profile)) or np.max(np.abs(profile)) < MOTIONLESS_SPEED:
        return None
    return profile


def sparc(speed: Sequence[float] | np.ndarray, dt: float) -> float:
    """Spectral arc length of a speed profile sampled every `dt` seconds, as RoboLab computes it.

    FFT length (next power of two >= N) x 4; one-sided magnitude spectrum (0 Hz to the Nyquist frequency)
    divided by its maximum; cutoff = min(10 Hz, the highest frequency whose normalised magnitude is >= 0.05);
    the frequencies <= cutoff are kept (from 0 Hz); fewer than 2 kept: 0; else minus the sum over consecutive
    kept points of sqrt((df / cutoff)^2 + dM^2). NaN with fewer than 2 samples or a motionless profile."""
    profile = _speed_profile(speed)
    if profile is None:
        return math.nan
    length = _next_power_of_two(profile.size) * SPARC_PAD_FACTOR
    magnitude = np.abs(np.fft.rfft(profile, length))
    magnitude = magnitude / magnitude.max()
    frequency = np.fft.rfftfreq(length, d=dt)
    cutoff = min(SPARC_CUTOFF_HZ, float(frequency[np.flatnonzero(magnitude >= SPARC_AMPLITUDE_THRESHOLD)[-1]]))
    kept = frequency <= cutoff
    if np.count_nonzero(kept) < 2:
        return 0.0
    step_f = np.diff(frequency[kept]) / cutoff
    step_m = np.diff(magnitude[kept])
    return -float(np.sum(np.sqrt(step_f**2 + step_m**2)))


def sparc_reference(
    speed: Sequence[float] | np.ndarray,
    dt: float,
    pad_level: int = SPARC_REFERENCE_PAD_LEVEL,
    cutoff_hz: float = SPARC_CUTOFF_HZ,
    threshold: float = SPARC_AMPLITUDE_THRESHOLD,
) -> float:
    """SPARC as the reference implementation of Balasubramanian et al. (2015) computes it; not RoboLab's.

    FFT length (next power of two >= N) x 2**pad_level; the two-sided magnitude spectrum (0 Hz up to the sampling
    rate) divided by its maximum; of the frequencies <= `cutoff_hz`, the span from the first to the last whose
    magnitude is >= `threshold`; minus its arc length with frequency divided by the span's width. Above the
    Nyquist frequency the two-sided spectrum mirrors lower frequencies, so at 15 Hz it reaches into that mirror.
    NaN with fewer than 2 samples or a motionless profile."""
    profile = _speed_profile(speed)
    if profile is None:
        return math.nan
    length = _next_power_of_two(profile.size) * 2**pad_level
    magnitude = np.abs(np.fft.fft(profile, length))
    magnitude = magnitude / magnitude.max()
    frequency = np.arange(length) / (length * dt)
    within = frequency <= cutoff_hz
    frequency, magnitude = frequency[within], magnitude[within]
    above = np.flatnonzero(magnitude >= threshold)
    frequency, magnitude = frequency[above[0] : above[-1] + 1], magnitude[above[0] : above[-1] + 1]
    if frequency.size < 2:
        return 0.0
    step_f = np.diff(frequency) / (frequency[-1] - frequency[0])
    return -float(np.sum(np.sqrt(step_f**2 + np.diff(magnitude) ** 2)))


def _as_samples(values: np.ndarray) -> np.ndarray:
    """A (T,) or (T, D) array as (T, D) float64."""
    values = np.asarray(values, dtype=np.float64)
    return values[:, None] if values.ndim == 1 else values.reshape(values.shape[0], -1)


def gradient_velocity(positions: np.ndarray, dt: float) -> np.ndarray:
    """Velocities of (T, D) samples by `np.gradient` (central differences inside, one-sided at the ends): (T, D)."""
    return np.gradient(_as_samples(positions), dt, axis=0)


def integrated_squared_jerk(velocity: np.ndarray, dt: float) -> float:
    """Trapezoidal integral over time of the squared jerk norm, jerk = two successive `np.gradient`s over dt of a
    (T, D) velocity (so three of positions passed through `gradient_velocity`). NaN with fewer than 3 samples."""
    velocity = _as_samples(velocity)
    if velocity.shape[0] < MIN_SAMPLES:
        return math.nan
    jerk = np.gradient(np.gradient(velocity, dt, axis=0), dt, axis=0)
    squared = np.sum(jerk**2, axis=1)
    return float(dt * (squared.sum() - 0.5 * (squared[0] + squared[-1])))


def path_length(positions: np.ndarray) -> float:
    """Sum of the segment lengths of a (T, D) path."""
    positions = _as_samples(positions)
    if positions.shape[0] < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(positions, axis=0), axis=-1).sum())


def _nanmean(values: Sequence[float]) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return float(np.mean(finite)) if finite else math.nan


def trajectory_metrics(
    ee_positions: np.ndarray,
    joint_positions: np.ndarray,
    joint_targets: np.ndarray,
    dt: float,
    joint_velocities: np.ndarray | None = None,
    ee_velocities: np.ndarray | None = None,
) -> dict[str, float]:
    """Every metric of `METRIC_KEYS` for one episode (all NaN with fewer than `MIN_SAMPLES` samples).

    Args:
        ee_positions: (S, 3) positions of the gripper's base link (m), S = T + 1: at reset, then after each step.
        joint_positions: (S, J) arm joint positions (rad), at the same instants.
        joint_targets: (T, J) commanded arm joint targets (rad) of each step; step t's error is its target minus
            the position reached after it (row t + 1).
        dt: seconds between samples (one control step).
        joint_velocities: (S, J) measured arm joint velocities (rad/s); None: `np.gradient` of the positions.
        ee_velocities: (S, 3) measured base-link velocities (m/s); None: `np.gradient` of the positions.
    """
    ee = _as_samples(ee_positions)
    joints = _as_samples(joint_positions)
    if ee.shape[0] < MIN_SAMPLES:
        return {key: math.nan for key in METRIC_KEYS}
    targets = np.asarray(joint_targets, dtype=np.float64).reshape(-1, joints.shape[1])
    ee_velocity = gradient_velocity(ee, dt) if ee_velocities is None else _as_samples(ee_velocities)
    joint_velocity = gradient_velocity(joints, dt) if joint_velocities is None else _as_samples(joint_velocities)
    ee_speed = np.linalg.norm(ee_velocity, axis=1)
    reached = joints[1 : 1 + targets.shape[0]]
    error = targets[: reached.shape[0]] - reached
    return {
        "ee_sparc": sparc(ee_speed, dt),
        "joint_sparc_mean": _nanmean([sparc(np.abs(joint_velocity[:, j]), dt) for j in range(joint_velocity.shape[1])]),
        "ee_isj": integrated_squared_jerk(ee_velocity, dt),
        "joint_isj": integrated_squared_jerk(joint_velocity, dt),
        "ee_path_length": path_length(ee),
        "ee_speed_max": float(ee_speed.max()),
        "ee_speed_mean": float(ee_speed.mean()),
        "joint_rmse_mean": float(np.mean(np.sqrt(np.mean(error**2, axis=0)))) if error.size else math.nan,
        "joint_tracking_max": float(np.abs(error).max()) if error.size else math.nan,
    }


def legacy_metrics(metrics: Mapping[str, Any]) -> dict[str, Any]:
    """A results-version-1 line's metrics under the names of `LEGACY_METRIC_NAMES` (others kept as they are)."""
    return {LEGACY_METRIC_NAMES.get(key, key): value for key, value in metrics.items()}


def event_tallies(events: Sequence[Mapping[str, Any]]) -> tuple[dict[str, int], dict[str, list[str]]]:
    """How often each event type fired, and which objects each object event fired for (sorted, distinct).

    Gripper events (hit table, fully closed, multiple objects grasped) have no object list."""
    from robolab_ms.tasks.events import OBJECT_EVENTS

    counts: dict[str, int] = {}
    objects: dict[str, set[str]] = {}
    for event in events:
        kind = str(event.get("type"))
        counts[kind] = counts.get(kind, 0) + 1
        if kind in OBJECT_EVENTS and event.get("object") is not None:
            objects.setdefault(kind, set()).add(str(event["object"]))
    return dict(sorted(counts.items())), {kind: sorted(names) for kind, names in sorted(objects.items())}
