"""Per-episode trajectory metrics and event tallies, computed from what the recorder saw at the control rate.

Trajectory metrics (RoboLab's set, all from samples at the control rate, 15 Hz):

| key | what | unit |
|---|---|---|
| `ee_sparc` | SPARC of the end-effector speed (closer to 0 = smoother; NaN when the end effector did not move) | - |
| `joint_sparc` | mean over the arm joints of the SPARC of each joint's speed (motionless joints left out) | - |
| `ee_jerk` | integrated squared jerk of the end-effector position, integral of the squared jerk norm | m^2/s^5 |
| `joint_jerk` | integrated squared jerk of the arm joint vector (squared norm over the joints) | rad^2/s^5 |
| `ee_path_length` | end-effector path length (sum of segment lengths) | m |
| `ee_speed_mean`, `ee_speed_max` | mean and largest end-effector speed | m/s |
| `joint_tracking_rmse` | root mean square of commanded arm target minus the position reached after that step | rad |
| `joint_tracking_max` | largest absolute commanded-minus-reached joint error | rad |

A value that cannot be computed (too few steps, no motion) is NaN; tables leave NaN out of their means.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

SPARC_CUTOFF_HZ = 10.0  # the highest frequency SPARC may look at
SPARC_AMPLITUDE_THRESHOLD = 0.05  # the adaptive cutoff: the last frequency whose normalised magnitude reaches this
SPARC_PAD_LEVEL = 4  # zero padding: next power of two of the length, times 2**SPARC_PAD_LEVEL
MOTIONLESS_SPEED = 1e-6  # a speed profile whose maximum stays below this (unit/s) has no SPARC

METRIC_KEYS = (
    "ee_sparc", "joint_sparc", "ee_jerk", "joint_jerk", "ee_path_length", "ee_speed_mean", "ee_speed_max",
    "joint_tracking_rmse", "joint_tracking_max",
)  # fmt: skip


def sparc(
    speed: Sequence[float] | np.ndarray,
    rate_hz: float,
    pad_level: int = SPARC_PAD_LEVEL,
    cutoff_hz: float = SPARC_CUTOFF_HZ,
    threshold: float = SPARC_AMPLITUDE_THRESHOLD,
) -> float:
    """Spectral arc length of a speed profile sampled at `rate_hz` (Balasubramanian et al., 2015).

    The profile's FFT magnitude (zero-padded to the next power of two of its length times 2**pad_level) is
    normalised by its value at 0 Hz; the spectrum is cut at the last frequency up to `cutoff_hz` whose normalised
    magnitude is at least `threshold`; SPARC is minus the arc length of that curve with frequency divided by the
    cutoff. Frequencies above the Nyquist frequency (rate_hz / 2) are mirror images of lower ones and are never
    counted, so at 15 Hz the effective cap is 7.5 Hz. Returns NaN for an empty or motionless profile.
    """
    profile = np.asarray(speed, dtype=np.float64).ravel()
    if profile.size < 2 or not np.all(np.isfinite(profile)) or np.max(np.abs(profile)) < MOTIONLESS_SPEED:
        return math.nan
    length = 1 << (int(math.ceil(math.log2(profile.size))) + pad_level)
    magnitude = np.abs(np.fft.rfft(profile, length))
    frequency = np.arange(magnitude.size) * (rate_hz / length)
    peak = magnitude[0]  # for a non-negative profile the spectrum peaks at 0 Hz
    if peak <= 0.0:
        peak = magnitude.max()
    magnitude = magnitude / peak
    within = frequency <= min(cutoff_hz, rate_hz / 2.0)
    frequency, magnitude = frequency[within], magnitude[within]
    above = np.flatnonzero(magnitude >= threshold)
    last = int(above[-1]) if above.size else 0
    if last == 0:  # the whole spectrum drops below the threshold at once: a single point, no arc
        return 0.0
    frequency, magnitude = frequency[: last + 1], magnitude[: last + 1]
    step_f = np.diff(frequency) / (frequency[-1] - frequency[0])
    step_m = np.diff(magnitude)
    return -float(np.sum(np.hypot(step_f, step_m)))


def speeds(positions: np.ndarray, rate_hz: float) -> np.ndarray:
    """Speed between consecutive samples of a (T, D) path: (T - 1,), in units per second."""
    positions = np.asarray(positions, dtype=np.float64)
    if positions.ndim == 1:
        positions = positions[:, None]
    return np.linalg.norm(np.diff(positions, axis=0), axis=-1) * rate_hz


def integrated_squared_jerk(positions: np.ndarray, rate_hz: float) -> float:
    """Integral over time of the squared norm of the third derivative of a (T, D) path (finite differences).

    NaN with fewer than 4 samples."""
    positions = np.asarray(positions, dtype=np.float64)
    if positions.ndim == 1:
        positions = positions[:, None]
    if positions.shape[0] < 4:
        return math.nan
    jerk = np.diff(positions, n=3, axis=0) * rate_hz**3
    return float(np.sum(jerk**2) / rate_hz)


def path_length(positions: np.ndarray) -> float:
    """Sum of the segment lengths of a (T, D) path."""
    positions = np.asarray(positions, dtype=np.float64)
    if positions.shape[0] < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(positions, axis=0), axis=-1).sum())


def _nanmean(values: Iterable[float]) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return float(np.mean(finite)) if finite else math.nan


def trajectory_metrics(
    ee_positions: np.ndarray, joint_positions: np.ndarray, joint_targets: np.ndarray, rate_hz: float
) -> dict[str, float]:
    """Every metric of `METRIC_KEYS` for one episode.

    Args:
        ee_positions: (T + 1, 3) end-effector positions (m), at reset then after each control step.
        joint_positions: (T + 1, J) arm joint positions (rad), at the same instants.
        joint_targets: (T, J) commanded arm joint targets (rad) of each step.
        rate_hz: the control rate.
    """
    ee = np.asarray(ee_positions, dtype=np.float64).reshape(-1, 3)
    joints = np.asarray(joint_positions, dtype=np.float64)
    joints = joints.reshape(joints.shape[0], -1)
    targets = np.asarray(joint_targets, dtype=np.float64).reshape(-1, joints.shape[1])
    ee_speed = speeds(ee, rate_hz)
    joint_speed = np.abs(np.diff(joints, axis=0)) * rate_hz  # (T, J)
    reached = joints[1 : 1 + targets.shape[0]]
    error = targets[: reached.shape[0]] - reached
    return {
        "ee_sparc": sparc(ee_speed, rate_hz),
        "joint_sparc": _nanmean(sparc(joint_speed[:, j], rate_hz) for j in range(joint_speed.shape[1])),
        "ee_jerk": integrated_squared_jerk(ee, rate_hz),
        "joint_jerk": integrated_squared_jerk(joints, rate_hz),
        "ee_path_length": path_length(ee),
        "ee_speed_mean": float(ee_speed.mean()) if ee_speed.size else math.nan,
        "ee_speed_max": float(ee_speed.max()) if ee_speed.size else math.nan,
        "joint_tracking_rmse": float(np.sqrt(np.mean(error**2))) if error.size else math.nan,
        "joint_tracking_max": float(np.abs(error).max()) if error.size else math.nan,
    }


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
