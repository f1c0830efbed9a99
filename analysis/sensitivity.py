"""Which varied parameters move a policy's outcome most: RoboLab's sensitivity analysis with sbi.

From episodes run with `robolab eval --vary ...`, each with its drawn variation parameters (theta) and its outcomes
(x: success, duration, score, ...), a neural posterior estimator learns p(theta | x). Sampling it at an observed
outcome x_o (by default success = 1) tells which parameter values that outcome comes from: a parameter whose
posterior stays where the episodes drew it does not matter to the outcome; one whose posterior moves (success only
in bright light) does.

Parameters:
- continuous ones are normalised to [0, 1] over the range they were drawn from: the run's manifest (`variations.ranges`
  of `robolab eval`, `params` of a synthetic folder), else the axis's default range (docs/variations.md), else the
  values seen; parameters the variation axis draws log-uniformly (light intensity, environment light) on a log scale,
  so every normalised parameter was drawn uniformly;
- categorical ones (light colour, background, ...) are label-encoded, labels in sorted order;
- a camera whose six offsets are recorded becomes one distance from its nominal pose, `cam_<camera>_dist` =
  ||(dx, dy, dz)|| + beta x the geodesic angle of the rotation (roll, pitch, yaw). The angles are read as
  `robolab_ms.variations.camera.offset_pose` applies them: static x, y, z axes (transforms3d "sxyz", R = Rz(yaw)
  Ry(pitch) Rx(roll)), composed after the nominal rotation, so the angle between nominal and moved camera is the
  angle of that R alone. The distance is normalised over the values seen.

Method (RoboLab's): sbi's MNPE when a parameter is categorical (continuous columns first, then the labels), plain NPE
otherwise; a uniform box prior (each continuous parameter uniform on [0, 1], each categorical one uniform over its
labels); 50 training epochs; 5000 posterior samples at x_o. Optionally (`reweight`) the samples are importance
weighted from the distribution the episodes were drawn from to the uniform prior, with a Gaussian kernel density
estimate of the drawn parameters, and the effective sample size is reported.

The ranking score, `shift`, is the largest change in probability the outcome makes to one set of values of the
parameter: the Kolmogorov-Smirnov distance (sets {theta <= t}) for a continuous parameter, the total variation
distance (any set of categories) for a categorical one. Both lie in [0, 1]: 0 = the posterior is the prior, 1 = they
share no values. The prior compared against is what the posterior would be if the outcome said nothing: the
episodes' own drawn values, or the uniform prior after reweighting.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robolab_ms.errors import RoboLabError, did_you_mean, make_folder

if TYPE_CHECKING:  # pandas, and torch through robolab_ms.analysis.runs, load when a command runs: `robolab --help`
    import pandas as pd  # stays fast

    from robolab_ms.analysis.runs import RunSet

DERIVED_OBSERVATIONS = {"success": "1 for a success, else 0", "duration": "episode length in seconds (steps / 15 Hz)"}
MIN_EPISODES = 20
TABLE_CSV = "sensitivity.csv"
TABLE_MD = "sensitivity.md"
SAMPLES_CSV = "posterior_samples.csv"
MARGINALS = "sensitivity_marginals"
PAIRS = "sensitivity_pairs"
PADDING = "_uniform_padding"  # MNPE needs one continuous column; added when every parameter is categorical

# recorded variation field -> (axis, axis parameter) it was drawn from; see docs/variations.md
_FIELDS: tuple[tuple[str, str, str], ...] = (
    (r"light_intensity", "lighting", "intensity"),
    (r"light_environment", "lighting", "environment"),
    (r"light_ambient", "lighting", "ambient"),
    (r"light_color", "lighting", "color"),
    (r"light_direction", "lighting", "direction"),
    (r"background", "background", "name"),
    (r"table_material", "table", "material"),
    (r"cam_wrist_(dx|dy)", "camera", "wrist_xy"),
    (r"cam_wrist_dz", "camera", "wrist_z"),
    (r"cam_wrist_(droll|dpitch|dyaw)", "camera", "wrist_rot"),
    (r"cam_.+_(dx|dy)", "camera", "external_xy"),
    (r"cam_.+_dz", "camera", "external_z"),
    (r"cam_.+_(droll|dpitch|dyaw)", "camera", "external_rot"),
    (r"obj_.+_(dx|dy)", "objects", "xy"),
    (r"obj_.+_dyaw", "objects", "yaw"),
    (r"robot_joint\d+_offset", "robot", "joints"),
    (r"image_noise_std", "noise", "std"),
    (r"distractor_.+_color", "distractors", "color"),
    (r"distractor_.+_texture", "distractors", "texture"),
)


def axis_parameter(column: str) -> tuple[str, str] | None:
    """The (axis, parameter) of `robolab_ms.variations` a recorded field is drawn from, or None."""
    for pattern, axis, param in _FIELDS:
        if re.fullmatch(pattern, column):
            return axis, param
    return None


@dataclass(frozen=True)
class Parameter:
    """One parameter of the analysis and how its values map to the normalised scale.

    kind: `continuous` (normalised to [0, 1] over [low, high], on a log scale when `log`) or `categorical` (labels
    0..K-1 for `categories`). `source` says where the range comes from (`manifest`, `axis default`, `observed`)."""

    name: str
    kind: str
    low: float = 0.0
    high: float = 1.0
    log: bool = False
    categories: tuple[str, ...] = ()
    source: str = "observed"
    description: str = ""

    def normalise(self, values: pd.Series) -> np.ndarray:
        if self.kind == "categorical":
            codes = {name: index for index, name in enumerate(self.categories)}
            return values.astype(str).map(codes).to_numpy(dtype=float)
        numbers = values.to_numpy(dtype=float)
        if self.log:
            return (np.log(numbers) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (numbers - self.low) / (self.high - self.low)

    def value(self, normalised: float) -> float:
        """A normalised value back in the parameter's own units."""
        if self.log:
            return float(math.exp(math.log(self.low) + normalised * (math.log(self.high) - math.log(self.low))))
        return float(self.low + normalised * (self.high - self.low))


@dataclass
class SensitivityResult:
    """A fitted sensitivity analysis: `table` ranks the parameters (columns in `rank_table`); `samples` are the
    posterior samples on the normalised scale (one column per parameter, continuous first), `weights` their
    importance weights (None without reweighting), `theta` the episodes' normalised parameters."""

    table: pd.DataFrame
    parameters: list[Parameter]
    samples: np.ndarray
    weights: np.ndarray | None
    theta: np.ndarray
    x_o: dict[str, float]
    observations: list[str]
    method: str
    episodes: int
    epochs_trained: int
    epochs: int
    seed: int
    fit_seconds: float
    effective_sample_size: float | None = None
    null_fits: int = 0
    notes: list[str] = field(default_factory=list)


# ---------------------------------------------------------------------------------------------------------- inputs


def camera_distance(offsets: np.ndarray, beta: float = 1.0) -> np.ndarray:
    """Distance of camera poses from the nominal one: ||(dx, dy, dz)|| + beta x geodesic angle of the rotation
    R = Rz(dyaw) Ry(dpitch) Rx(droll) (static x, y, z axes, as `variations.camera.offset_pose` applies them).
    `offsets`: (..., 6) in the order dx, dy, dz, droll, dpitch, dyaw (metres, radians)."""
    offsets = np.asarray(offsets, dtype=float)
    translation = np.linalg.norm(offsets[..., :3], axis=-1)
    return translation + beta * rotation_angle(offsets[..., 3], offsets[..., 4], offsets[..., 5])


def rotation_angle(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Angle (rad, 0..pi) of the rotation Rz(yaw) Ry(pitch) Rx(roll); exact for small angles too
    (from ||R - I||_F = 2 sqrt(2) sin(angle / 2))."""
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    matrix = np.stack(
        [
            np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], axis=-1),
            np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], axis=-1),
            np.stack([-sp, cp * sr, cp * cr], axis=-1),
        ],
        axis=-2,
    )
    difference = np.linalg.norm(matrix - np.eye(3), axis=(-2, -1))
    return 2.0 * np.arcsin(np.clip(difference / (2.0 * math.sqrt(2.0)), 0.0, 1.0))


def variation_columns(runs: RunSet) -> list[str]:
    """The episodes' columns that hold drawn variation parameters (fields of docs/variations.md, or the parameters
    a synthetic folder's manifest lists), with at least one recorded value."""
    listed = set()
    for manifest in _manifests(runs):
        listed.update(_mapping(manifest.get("params")) if manifest.get("synthetic") else {})
    episodes = runs.episodes
    return [
        column
        for column in episodes.columns
        if (axis_parameter(column) or column in listed) and episodes[column].notna().any()
    ]


def _manifests(runs: RunSet) -> list[dict]:
    """The folders' manifests; one that cannot be read, or is no JSON object, leaves the axis defaults or the
    observed range (as do entries of the wrong shape in one, see `_recorded_ranges`)."""
    manifests = []
    for folder in runs.folders:
        path = Path(folder) / "manifest.json"
        if path.exists():
            try:
                manifest = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, json.JSONDecodeError):
                continue
            if isinstance(manifest, dict):
                manifests.append(manifest)
    return manifests


def _mapping(value: Any) -> dict:
    """A manifest entry that should be an object, or an empty one when it is something else."""
    return value if isinstance(value, dict) else {}


def _recorded_ranges(runs: RunSet) -> dict[str, list[tuple[float, float, bool]]]:
    """column or (axis.param) -> the (low, high, log) ranges the runs' manifests record for it."""
    from robolab_ms.variations.settings import AXES

    ranges: dict[str, list[tuple[float, float, bool]]] = {}
    for manifest in _manifests(runs):
        if manifest.get("synthetic"):
            for name, values in _mapping(manifest.get("params")).items():
                if _is_number_pair(values):
                    ranges.setdefault(name, []).append((float(values[0]), float(values[1]), False))
        for axis, params in _mapping(_mapping(manifest.get("variations")).get("ranges")).items():
            for param, values in _mapping(params).items():
                if _is_number_pair(values) and axis in AXES:
                    log = any(p.name == param and p.log for p in AXES[axis].params)
                    ranges.setdefault(f"{axis}.{param}", []).append((float(values[0]), float(values[1]), log))
    return ranges


def _is_number_pair(values: Any) -> bool:
    return (
        isinstance(values, (list, tuple))
        and len(values) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values)
    )


def _continuous_parameter(column: str, values: pd.Series, recorded: dict) -> tuple[Parameter, str | None]:
    """The parameter with its range (manifest, axis default, else observed); a note when the range was widened."""
    from robolab_ms.variations.base import Uniform
    from robolab_ms.variations.settings import AXES

    seen_low, seen_high = float(values.min()), float(values.max())
    candidates: list[tuple[float, float, bool]] = []
    source = "observed"
    where = axis_parameter(column)
    if column in recorded:
        candidates, source = recorded[column], "manifest"
    elif where and f"{where[0]}.{where[1]}" in recorded:
        candidates, source = recorded[f"{where[0]}.{where[1]}"], "manifest"
    elif where:
        default = next((p.default for p in AXES[where[0]].params if p.name == where[1]), None)
        if isinstance(default, Uniform) and not default.fixed:
            candidates, source = [(default.low, default.high, default.log)], "axis default"
    note = None
    if candidates:
        low = min(c[0] for c in candidates)
        high = max(c[1] for c in candidates)
        log = all(c[2] for c in candidates) and low > 0
        tolerance = 1e-6 * max(1.0, abs(high - low))
        if high > low and seen_low >= low - tolerance and seen_high <= high + tolerance:
            return Parameter(column, "continuous", low, high, log, source=source), None
        note = (
            f"{column}: values {seen_low:g}..{seen_high:g} lie outside its {source} range {low:g}..{high:g}; "
            "normalised over the values seen"
        )
    return Parameter(column, "continuous", seen_low, seen_high, False, source="observed"), note


def _camera_groups(columns: Sequence[str]) -> dict[str, list[str]]:
    """camera name -> its six offset columns, for the cameras with all six among `columns`."""
    from robolab_ms.variations.camera import OFFSETS

    present = set(columns)
    groups = {}
    for column in columns:
        match = re.fullmatch(r"cam_(.+)_dx", column)
        if match:
            names = [f"cam_{match.group(1)}_{offset}" for offset in OFFSETS]
            if all(name in present for name in names):
                groups[match.group(1)] = names
    return groups


def _split(values: Sequence[str] | None) -> list[str]:
    """Names given as `a,b c` (commas and/or separate words)."""
    return [part.strip() for value in values or [] for part in value.split(",") if part.strip()]


def parse_at(values: Sequence[str] | None) -> dict[str, float]:
    """`success=1,duration=6` -> {"success": 1.0, "duration": 6.0}."""
    at: dict[str, float] = {}
    for item in _split(values):
        name, sign, number = item.partition("=")
        try:
            if not sign:
                raise ValueError
            at[name.strip()] = float(number)
        except ValueError:
            raise RoboLabError(
                f"--at '{item}': write OBSERVATION=NUMBER, e.g. --at success=1 or --at success=0,duration=6"
            ) from None
    return at


@dataclass
class _Inputs:
    parameters: list[Parameter]
    theta: np.ndarray
    x: np.ndarray
    observations: list[str]
    notes: list[str]


def prepare(
    runs: RunSet,
    params: Sequence[str] | None = None,
    observations: Sequence[str] = ("success",),
    beta: float = 1.0,
    policy: str | None = None,
    tasks: Sequence[str] | None = None,
) -> _Inputs:
    """The normalised parameters (theta, continuous first) and observations (x) of the chosen episodes; raises
    RoboLabError naming the fix for anything that cannot be analysed."""
    import pandas as pd

    from robolab_ms.analysis.runs import RunSet

    notes: list[str] = []
    episodes = runs.episodes
    where = ", ".join(str(folder) for folder in runs.folders)
    if tasks:
        unknown = sorted(set(tasks) - set(episodes["task"]))
        if unknown:
            raise RoboLabError(
                f"--task {' '.join(unknown)}: no episodes of it in {where}. "
                f"{did_you_mean(unknown[0], episodes['task'].unique())}"
            )
        episodes = episodes[episodes["task"].isin(tasks)]
    policies = sorted(episodes["policy"].unique())
    if policy is not None:
        if policy not in policies:
            raise RoboLabError(f"--policy {policy}: no episodes of it in {where}. {did_you_mean(policy, policies)}")
        episodes = episodes[episodes["policy"] == policy]
    elif len(policies) > 1:
        raise RoboLabError(
            f"{where} hold episodes of {len(policies)} policies ({', '.join(policies)}); a sensitivity "
            "analysis is of one policy: choose it with --policy NAME"
        )
    errored = episodes["error"].notna() if "error" in episodes else pd.Series(False, index=episodes.index)
    if errored.any():
        notes.append(f"{int(errored.sum())} errored episode(s) left out (their outcome is not the policy's)")
        episodes = episodes[~errored]

    available = variation_columns(RunSet(episodes, runs.folders))
    if not available:
        raise RoboLabError(
            f"no drawn variation parameters in the episodes of {where}: run the policy with "
            "domain randomization, e.g. `robolab eval --policy P --task T --episodes 100 "
            "--vary lighting,camera,objects --out DIR` (docs/variations.md), then analyse "
            "DIR"
        )
    cameras = _camera_groups(available)
    camera_columns = {column for names in cameras.values() for column in names}
    choices = [f"cam_{camera}_dist" for camera in cameras] + [c for c in available if c not in camera_columns]
    derived = {f"cam_{camera}_dist": names for camera, names in cameras.items()}
    if params:
        chosen = _split(params)
        for name in chosen:
            if name not in choices and name not in available:
                raise RoboLabError(
                    f"--params: '{name}' is not a varied parameter of these episodes. "
                    f"{did_you_mean(name, choices)} Available: {', '.join(choices)}"
                )
        if len(set(chosen)) != len(chosen):
            raise RoboLabError(f"--params: a parameter is named twice in {', '.join(chosen)}")
        needed = [c for name in chosen for c in derived.get(name, [name])]
        missing = episodes[needed].isna().any(axis=1)
        if missing.any():
            notes.append(f"{int(missing.sum())} episode(s) without a value of every chosen parameter left out")
            episodes = episodes[~missing]
    else:
        complete = [name for name in choices if episodes[derived.get(name, [name])].notna().all(axis=None)]
        partial = [name for name in choices if name not in complete]
        if partial:
            notes.append(
                f"left out, recorded for some episodes only: {', '.join(partial)} (name them with --params "
                "to analyse the episodes that have them)"
            )
        chosen = [name for name in complete if episodes[derived.get(name, [name])].nunique(dropna=True).max() > 1]
        fixed = [name for name in complete if name not in chosen]
        if fixed:
            notes.append(f"left out, one value in every episode: {', '.join(fixed)}")
        if not chosen:
            raise RoboLabError(
                f"no parameter takes more than one value in the episodes of {where}; run with "
                "--vary over ranges (e.g. --vary lighting,camera), not fixed conditions"
            )

    x, observation_names = _observations(episodes, observations, where)
    if len(episodes) < MIN_EPISODES:
        raise RoboLabError(
            f"{len(episodes)} usable episode(s) in {where}; a sensitivity analysis needs at least "
            f"{MIN_EPISODES} (RoboLab fits thousands): run more episodes with --episodes N"
        )

    recorded = _recorded_ranges(runs)
    parameters, columns = [], []
    for name in chosen:
        if name in derived:
            values = pd.Series(camera_distance(episodes[derived[name]].to_numpy(dtype=float), beta), name=name)
            parameter = Parameter(
                name,
                "continuous",
                float(values.min()),
                float(values.max()),
                source="observed",
                description=f"translation + {beta:g} x rotation angle from the nominal pose",
            )
        else:
            values = episodes[name].reset_index(drop=True)
            numeric = pd.to_numeric(values, errors="coerce")
            if numeric.notna().all() and values.map(lambda v: not isinstance(v, (str, bool))).all():
                values = numeric
                parameter, note = _continuous_parameter(name, values, recorded)
                if note:
                    notes.append(note)
            else:
                parameter = Parameter(name, "categorical", categories=tuple(sorted(values.astype(str).unique())))
        if (parameter.kind == "continuous" and parameter.high <= parameter.low) or (
            parameter.kind == "categorical" and len(parameter.categories) < 2
        ):
            raise RoboLabError(
                f"--params: '{name}' takes one value in every chosen episode; nothing to learn about it: leave it out"
            )
        parameters.append(parameter)
        columns.append(parameter.normalise(values.reset_index(drop=True)))
    order = sorted(range(len(parameters)), key=lambda i: parameters[i].kind == "categorical")
    parameters = [parameters[i] for i in order]
    theta = np.stack([columns[i] for i in order], axis=1)
    return _Inputs(parameters, theta, x, observation_names, notes)


def _observations(episodes: pd.DataFrame, names: Sequence[str], where: str) -> tuple[np.ndarray, list[str]]:
    import pandas as pd

    from robolab_ms.tasks.spec import CONTROL_HZ

    chosen = _split(names) or ["success"]
    numeric = [
        c
        for c in episodes.columns
        if c not in DERIVED_OBSERVATIONS
        and pd.api.types.is_numeric_dtype(episodes[c])
        and not axis_parameter(c)
        and episodes[c].notna().any()
    ]
    columns = []
    for name in chosen:
        if name == "success":
            values = episodes["success"].astype(float)
        elif name == "duration":
            values = episodes["steps"].astype(float) / CONTROL_HZ
        elif name in numeric:
            values = episodes[name].astype(float)
        else:
            known = [*DERIVED_OBSERVATIONS, *numeric]
            raise RoboLabError(
                f"--obs: '{name}' is not an outcome of these episodes. {did_you_mean(name, known)} "
                f"Available: {', '.join(known)}"
            )
        if values.isna().any():
            raise RoboLabError(
                f"--obs: '{name}' has no value for {int(values.isna().sum())} episode(s) (e.g. "
                "time_to_success_s of failures); choose an outcome every episode has"
            )
        if values.nunique() < 2:
            raise RoboLabError(
                f"--obs: '{name}' is {values.iloc[0]:g} in every episode of {where}, so no parameter "
                "can explain it; choose an outcome that varies (e.g. --obs duration or score) or "
                "add episodes where it does"
            )
        columns.append(values.to_numpy())
    if len(set(chosen)) != len(chosen):
        raise RoboLabError(f"--obs: an outcome is named twice in {', '.join(chosen)}")
    return np.stack(columns, axis=1), chosen


def observed_outcome(x: np.ndarray, observations: Sequence[str], at: Mapping[str, float]) -> dict[str, float]:
    """x_o: the values `at` gives; success = 1 when not given; any other outcome not given takes its median over
    the episodes that match the given ones (over all episodes when none match)."""
    for name in at:
        if name not in observations:
            raise RoboLabError(
                f"--at {name}=...: '{name}' is not among --obs ({', '.join(observations)}); add it "
                "to --obs or leave it out of --at"
            )
    given = dict(at)
    if "success" in observations and "success" not in given:
        given["success"] = 1.0
    if "success" in given and given["success"] not in (0.0, 1.0):
        raise RoboLabError(f"--at success={given['success']:g}: success is 0 or 1")
    match = np.ones(len(x), dtype=bool)
    for name, value in given.items():
        match &= np.isclose(x[:, observations.index(name)], value)
    rows = x[match] if match.any() else x
    return {
        name: float(given[name]) if name in given else float(np.median(rows[:, i]))
        for i, name in enumerate(observations)
    }


# ---------------------------------------------------------------------------------------------------------- fitting


class _NoTracking:
    """An sbi tracker that keeps nothing (sbi's default writes TensorBoard logs into the working folder)."""

    log_dir = None

    def log_metric(self, name: str, value: float, step: int | None = None) -> None:
        pass

    def log_metrics(self, metrics: dict, step: int | None = None) -> None:
        pass

    def log_params(self, params: dict) -> None:
        pass

    def add_figure(self, name: str, figure: Any, step: int | None = None) -> None:
        pass

    def flush(self) -> None:
        pass


def fit_posterior_samples(
    theta: np.ndarray,
    categories: Sequence[int],
    x: np.ndarray,
    x_o: np.ndarray,
    epochs: int = 50,
    samples: int = 5000,
    seed: int = 0,
    batch_size: int = 200,
    threads: int = 1,
) -> tuple[np.ndarray, str, int, float]:
    """Train sbi's MNPE (when `categories`, the label counts of the last len(categories) columns, is not empty) or
    NPE on (theta, x) and draw `samples` posterior samples at x_o. Returns (samples, method, epochs trained, fit
    seconds). The same inputs and seed give the same samples."""
    import torch
    from sbi.inference import MNPE, NPE
    from sbi.utils import BoxUniform

    continuous = theta.shape[1] - len(categories)
    high = [1.0] * continuous + [float(k - 1) for k in categories]
    previous_threads = torch.get_num_threads()
    torch.set_num_threads(threads)
    torch.manual_seed(seed)
    start = time.perf_counter()
    try:
        prior = BoxUniform(torch.zeros(len(high)), torch.tensor(high))
        method = MNPE if categories else NPE
        inference = method(prior=prior, tracker=_NoTracking(), show_progress_bars=False)
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")  # sbi's notes on column order, convergence and deprecated torch calls
            inference.append_simulations(
                torch.as_tensor(theta, dtype=torch.float32), torch.as_tensor(x, dtype=torch.float32)
            )
            # sbi counts epochs from 0 to max_num_epochs inclusive: epochs - 1 trains `epochs` epochs
            inference.train(max_num_epochs=epochs - 1, training_batch_size=batch_size)
            posterior = inference.build_posterior()
            fit_seconds = time.perf_counter() - start
            drawn = posterior.sample(
                (samples,), x=torch.as_tensor(x_o, dtype=torch.float32)[None], show_progress_bars=False
            )
    finally:
        torch.set_num_threads(previous_threads)
    epochs_trained = int(inference.summary["epochs_trained"][-1]) if inference.summary.get("epochs_trained") else 0
    return drawn.numpy().astype(float), "MNPE" if categories else "NPE", epochs_trained, fit_seconds


def kde_density(points: np.ndarray, data: np.ndarray, chunk: int = 512) -> np.ndarray:
    """Gaussian kernel density estimate of `data` (N, d) at `points` (M, d), both in [0, 1]^d: a product of
    one-dimensional Gaussians with Scott's bandwidth per dimension, reflected at 0 and 1 so the density of values
    drawn uniformly stays flat up to the edges."""
    count, dims = data.shape
    spread = np.maximum(data.std(axis=0, ddof=1), 1e-3)
    bandwidth = spread * count ** (-1.0 / (dims + 4))
    density = np.empty(len(points))
    for start in range(0, len(points), chunk):
        block = points[start : start + chunk]
        kernel = np.ones((len(block), count))
        for d in range(dims):
            centre = data[None, :, d]
            value = block[:, d, None]
            h = bandwidth[d]
            kernel *= (
                np.exp(-0.5 * ((value - centre) / h) ** 2)
                + np.exp(-0.5 * ((value + centre) / h) ** 2)
                + np.exp(-0.5 * ((value - (2.0 - centre)) / h) ** 2)
            ) / (h * math.sqrt(2 * math.pi))
        density[start : start + chunk] = kernel.mean(axis=1)
    return density


def importance_weights(samples: np.ndarray, theta: np.ndarray, parameters: Sequence[Parameter]) -> np.ndarray:
    """Weights that turn posterior samples under the episodes' drawing distribution into samples under the uniform
    prior: 1 / (KDE of the drawn continuous parameters x the drawn frequency of each category), summing to 1."""
    continuous = [i for i, p in enumerate(parameters) if p.kind == "continuous" and p.name != PADDING]
    density = kde_density(samples[:, continuous], theta[:, continuous]) if continuous else np.ones(len(samples))
    for i, parameter in enumerate(parameters):
        if parameter.kind == "categorical":
            frequency = np.bincount(theta[:, i].astype(int), minlength=len(parameter.categories)) / len(theta)
            density = density * frequency[samples[:, i].astype(int)]
    weights = 1.0 / np.maximum(density, 1e-12)
    return weights / weights.sum()


def effective_sample_size(weights: np.ndarray) -> float:
    """(sum w)^2 / sum w^2: how many unweighted samples the weighted ones are worth."""
    return float(weights.sum() ** 2 / np.square(weights).sum())


# ---------------------------------------------------------------------------------------------------------- summary


def weighted_quantile(values: np.ndarray, weights: np.ndarray, quantiles: Sequence[float]) -> np.ndarray:
    order = np.argsort(values)
    cumulative = np.cumsum(weights[order])
    cumulative /= cumulative[-1]
    return np.interp(quantiles, cumulative - weights[order] / (2 * weights.sum()), values[order])


def ks_distance(values: np.ndarray, weights: np.ndarray, reference: np.ndarray | None) -> float:
    """Kolmogorov-Smirnov distance between the weighted sample `values` and `reference` (a sample, equally
    weighted), or the uniform distribution on [0, 1] when `reference` is None."""
    order = np.argsort(values)
    sorted_values = values[order]
    cumulative = np.cumsum(weights[order]) / weights.sum()
    grid = np.unique(np.concatenate([sorted_values, [] if reference is None else reference, [0.0, 1.0]]))

    def posterior_cdf(points: np.ndarray, side: str) -> np.ndarray:
        index = np.searchsorted(sorted_values, points, side=side)
        return np.where(index > 0, cumulative[np.maximum(index - 1, 0)], 0.0)

    if reference is None:
        reference_cdf = {side: np.clip(grid, 0.0, 1.0) for side in ("left", "right")}
    else:
        sorted_reference = np.sort(reference)
        reference_cdf = {
            side: np.searchsorted(sorted_reference, grid, side=side) / len(reference) for side in ("left", "right")
        }
    return float(max(np.abs(posterior_cdf(grid, side) - reference_cdf[side]).max() for side in ("left", "right")))


def rank_table(
    parameters: Sequence[Parameter],
    samples: np.ndarray,
    weights: np.ndarray,
    theta: np.ndarray,
    uniform_reference: bool,
) -> pd.DataFrame:
    """One row per parameter, ranked by `shift` (largest first). Columns: rank, parameter, kind, shift,
    posterior_mean, ci95_low, ci95_high, prior_mean (normalised scale, continuous parameters), value_mean,
    value_ci95_low, value_ci95_high (the parameter's own units), top_category, top_posterior, top_prior
    (categorical parameters: the most probable category and its probability after and before), range_low,
    range_high, log_scale, range_source."""
    import pandas as pd

    rows = []
    for i, parameter in enumerate(parameters):
        if parameter.name == PADDING:
            continue
        values, drawn = samples[:, i], theta[:, i]
        row: dict[str, Any] = {"parameter": parameter.name, "kind": parameter.kind}
        if parameter.kind == "continuous":
            mean = float(np.sum(weights * values))
            low, high = weighted_quantile(values, weights, [0.025, 0.975])
            row.update(
                shift=ks_distance(values, weights, None if uniform_reference else drawn),
                posterior_mean=mean,
                ci95_low=float(low),
                ci95_high=float(high),
                prior_mean=0.5 if uniform_reference else float(drawn.mean()),
                value_mean=parameter.value(mean),
                value_ci95_low=parameter.value(low),
                value_ci95_high=parameter.value(high),
                range_low=parameter.low,
                range_high=parameter.high,
                log_scale=parameter.log,
                range_source=parameter.source,
            )
        else:
            count = len(parameter.categories)
            posterior = np.bincount(values.astype(int), weights=weights, minlength=count) / weights.sum()
            prior = (
                np.full(count, 1.0 / count)
                if uniform_reference
                else np.bincount(drawn.astype(int), minlength=count) / len(drawn)
            )
            top = int(np.argmax(posterior))
            row.update(
                shift=float(0.5 * np.abs(posterior - prior).sum()),
                top_category=parameter.categories[top],
                top_posterior=float(posterior[top]),
                top_prior=float(prior[top]),
                range_source="labels",
            )
        rows.append(row)
    columns = [
        "rank",
        "parameter",
        "kind",
        "shift",
        "posterior_mean",
        "ci95_low",
        "ci95_high",
        "prior_mean",
        "value_mean",
        "value_ci95_low",
        "value_ci95_high",
        "top_category",
        "top_posterior",
        "top_prior",
        "range_low",
        "range_high",
        "log_scale",
        "range_source",
    ]
    table = pd.DataFrame(rows).sort_values(["shift", "parameter"], ascending=[False, True], kind="stable")
    table.insert(0, "rank", range(1, len(table) + 1))
    return table.reindex(columns=columns).reset_index(drop=True)


def analyse(
    runs: RunSet,
    params: Sequence[str] | None = None,
    observations: Sequence[str] = ("success",),
    at: Mapping[str, float] | None = None,
    epochs: int = 50,
    samples: int = 5000,
    seed: int = 0,
    beta: float = 1.0,
    reweight: bool = False,
    policy: str | None = None,
    tasks: Sequence[str] | None = None,
    batch_size: int = 200,
    threads: int = 1,
    null_fits: int = 0,
) -> SensitivityResult:
    """The sensitivity analysis of one policy's episodes in `runs` (see the module docstring). With `null_fits` K,
    K more fits on the outcomes shuffled across episodes (so no parameter can matter) give each parameter's
    `null_shift`, the largest shift it shows by chance."""
    if epochs < 1 or samples < 10 or batch_size < 2 or null_fits < 0:
        raise RoboLabError(
            f"--epochs {epochs}, --samples {samples}, --batch-size {batch_size}, --null {null_fits}: "
            "give at least 1 epoch, 10 samples, a batch of 2 and 0 null fits"
        )
    if not math.isfinite(beta) or beta < 0:
        raise RoboLabError(f"--beta {beta}: give a weight of 0 or more for the rotation angle (RoboLab: 1)")
    inputs = prepare(runs, params, observations, beta, policy, tasks)
    x_o = observed_outcome(inputs.x, inputs.observations, at or {})
    parameters, theta = inputs.parameters, inputs.theta
    if all(p.kind == "categorical" for p in parameters):
        padding = np.random.default_rng(seed).uniform(0.0, 1.0, len(theta))
        parameters = [Parameter(PADDING, "continuous", source="independent uniform"), *parameters]
        theta = np.column_stack([padding, theta])
    categories = [len(p.categories) for p in parameters if p.kind == "categorical"]
    outcome = np.array([x_o[name] for name in inputs.observations])
    drawn, method, trained, seconds = fit_posterior_samples(
        theta, categories, inputs.x, outcome, epochs, samples, seed, batch_size, threads
    )
    weights = importance_weights(drawn, theta, parameters) if reweight else np.full(len(drawn), 1.0 / len(drawn))
    table = rank_table(parameters, drawn, weights, theta, uniform_reference=reweight)
    if null_fits:
        null_shift: dict[str, float] = {}
        for k in range(1, null_fits + 1):
            shuffled = inputs.x[np.random.default_rng([seed, k]).permutation(len(inputs.x))]
            null_drawn = fit_posterior_samples(
                theta, categories, shuffled, outcome, epochs, samples, seed + k, batch_size, threads
            )[0]
            null_weights = (
                importance_weights(null_drawn, theta, parameters)
                if reweight
                else np.full(len(null_drawn), 1.0 / len(null_drawn))
            )
            null_table = rank_table(parameters, null_drawn, null_weights, theta, uniform_reference=reweight)
            for name, value in zip(null_table["parameter"], null_table["shift"]):
                null_shift[name] = max(null_shift.get(name, 0.0), float(value))
        table.insert(table.columns.get_loc("shift") + 1, "null_shift", table["parameter"].map(null_shift))
    keep = [i for i, p in enumerate(parameters) if p.name != PADDING]
    notes = list(inputs.notes)
    ess = effective_sample_size(weights) if reweight else None
    if ess is not None and ess < 0.1 * len(drawn):
        notes.append(f"effective sample size {ess:.0f} of {len(drawn)}: the reweighted numbers rest on few samples")
    if len(keep) < len(parameters):
        notes.append(
            "every parameter is categorical: an independent uniform column was added for MNPE (it needs "
            "one continuous parameter) and left out of the results"
        )
    return SensitivityResult(
        table=table,
        parameters=[parameters[i] for i in keep],
        samples=drawn[:, keep],
        weights=weights if reweight else None,
        theta=theta[:, keep],
        x_o=x_o,
        observations=inputs.observations,
        method=method,
        episodes=len(theta),
        epochs_trained=trained,
        epochs=epochs,
        seed=seed,
        fit_seconds=seconds,
        effective_sample_size=ess,
        null_fits=null_fits,
        notes=notes,
    )


# ---------------------------------------------------------------------------------------------------------- output


def to_markdown(result: SensitivityResult, timing: bool = False) -> str:
    """The ranking as Markdown, with what was fitted and at which outcome (and the fit's seconds with `timing`:
    left out of the file, so the same analysis writes the same file)."""
    outcome = ", ".join(f"{name} = {value:g}" for name, value in result.x_o.items())
    reference = "the uniform prior (samples reweighted)" if result.weights is not None else "the episodes' drawn values"
    null = result.null_fits > 0
    lines = [
        f"Sensitivity of {', '.join(result.observations)} to the varied parameters: {result.method}, "
        f"{result.episodes} episodes, {result.epochs_trained} of {result.epochs} epochs, {len(result.samples)} "
        f"posterior samples at {outcome}, seed {result.seed}.",
        "",
        f"shift: the largest change of probability the outcome makes to one set of values, measured against "
        f"{reference}: 0 = none, 1 = no overlap (Kolmogorov-Smirnov for numbers, total variation for categories). "
        "Mean and 95 % interval on the normalised scale (0 = range low, 1 = range high), then in the parameter's "
        "units.",
    ]
    if null:
        lines.append(
            f"null: the largest shift of the parameter in {result.null_fits} fit(s) on outcomes shuffled "
            "across episodes, where no parameter matters; a shift not well above it is noise."
        )
    lines += [
        "",
        "| rank | parameter | shift |" + (" null |" if null else "") + " posterior mean [95 % CI] | prior mean "
        "| in units | range |",
        "|---|---|---|" + ("---|" if null else "") + "---|---|---|---|",
    ]
    for row in result.table.itertuples(index=False):
        shift = f"{row.shift:.3f} |" + (f" {row.null_shift:.3f} |" if null else "")
        if row.kind == "continuous":
            scale = " (log)" if row.log_scale else ""
            lines.append(
                f"| {row.rank} | {row.parameter} | {shift} {row.posterior_mean:.2f} "
                f"[{row.ci95_low:.2f}, {row.ci95_high:.2f}] | {row.prior_mean:.2f} | {row.value_mean:.3g} "
                f"[{row.value_ci95_low:.3g}, {row.value_ci95_high:.3g}] | "
                f"{row.range_low:.3g}..{row.range_high:.3g}{scale}, {row.range_source} |"
            )
        else:
            lines.append(
                f"| {row.rank} | {row.parameter} | {shift} most probable: {row.top_category} "
                f"{row.top_posterior:.2f} | {row.top_prior:.2f} | - | categories |"
            )
    if result.effective_sample_size is not None:
        lines += [
            "",
            f"Importance reweighting to the uniform prior: effective sample size "
            f"{result.effective_sample_size:.0f} of {len(result.samples)}.",
        ]
    if timing:
        lines += ["", f"Fit: {result.fit_seconds:.1f} s (training and building the posterior, one fit)."]
    if result.notes:
        lines += ["", *[f"- {note}" for note in result.notes]]
    return "\n".join(lines) + "\n"


def _tick_labels(parameter: Parameter) -> tuple[list[float], list[str]]:
    if parameter.kind == "categorical":
        return list(range(len(parameter.categories))), list(parameter.categories)
    return [0.0, 0.5, 1.0], [f"{parameter.value(t):.3g}" for t in (0.0, 0.5, 1.0)]


def _axis_limits(parameter: Parameter) -> tuple[float, float]:
    return (-0.5, len(parameter.categories) - 0.5) if parameter.kind == "categorical" else (0.0, 1.0)


def _bins(parameter: Parameter, count: int = 25) -> np.ndarray:
    if parameter.kind == "categorical":
        return np.arange(len(parameter.categories) + 1) - 0.5
    return np.linspace(0.0, 1.0, count + 1)


def _shift(result: SensitivityResult, name: str, column: str = "shift") -> float:
    return float(result.table.loc[result.table["parameter"] == name, column].iloc[0])


def plot_marginals(result: SensitivityResult, out_stem: Path) -> list[Path]:
    """One panel per parameter (in rank order): posterior histogram against the prior; PNG and SVG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    order = [next(i for i, p in enumerate(result.parameters) if p.name == name) for name in result.table["parameter"]]
    columns = min(3, len(order))
    rows = math.ceil(len(order) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.0 * columns, 2.9 * rows), squeeze=False)
    weights = result.weights if result.weights is not None else np.full(len(result.samples), 1 / len(result.samples))
    for panel, i in zip(axes.flat, order):
        parameter = result.parameters[i]
        bins = _bins(parameter)
        panel.hist(
            result.samples[:, i],
            bins=bins,
            weights=weights,
            density=True,
            color="#3b75af",
            alpha=0.65,
            label="posterior",
        )
        if result.weights is not None:  # one value per bin: the uniform density
            panel.hist(
                (bins[:-1] + bins[1:]) / 2,
                bins=bins,
                density=True,
                histtype="step",
                color="black",
                linewidth=1.4,
                label="prior (uniform)",
            )
        else:
            panel.hist(
                result.theta[:, i],
                bins=bins,
                density=True,
                histtype="step",
                color="black",
                linewidth=1.4,
                label="prior (episodes' draws)",
            )
        ticks, labels = _tick_labels(parameter)
        panel.set_xticks(ticks, labels, rotation=30 if parameter.kind == "categorical" else 0, fontsize=8)
        panel.set_xlim(*_axis_limits(parameter))
        scale = ", log scale" if parameter.log else ""
        null = f" (null {_shift(result, parameter.name, 'null_shift'):.2f})" if result.null_fits else ""
        panel.set_title(f"{parameter.name}\nshift {_shift(result, parameter.name):.2f}{null}{scale}", fontsize=9)
        panel.set_ylabel("density" if parameter.kind == "continuous" else "probability", fontsize=8)
        panel.tick_params(axis="y", labelsize=8)
    for panel in list(axes.flat)[len(order) :]:
        panel.axis("off")
    axes.flat[0].legend(fontsize=7, loc="upper left")
    outcome = ", ".join(f"{name} = {value:g}" for name, value in result.x_o.items())
    figure.suptitle(f"{result.method} posterior at {outcome} ({result.episodes} episodes)", fontsize=10)
    figure.tight_layout()
    return _save(figure, out_stem)


def plot_pairs(result: SensitivityResult, out_stem: Path, most: int = 6) -> list[Path]:
    """Corner plot of the `most` highest-ranked parameters: marginals on the diagonal, pairwise posterior
    histograms below it; PNG and SVG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(result.table["parameter"])[:most]
    order = [next(i for i, p in enumerate(result.parameters) if p.name == name) for name in names]
    count = len(order)
    figure, axes = plt.subplots(count, count, figsize=(2.3 * count + 0.6, 2.3 * count + 0.4), squeeze=False)
    weights = result.weights if result.weights is not None else np.full(len(result.samples), 1 / len(result.samples))
    for row, i in enumerate(order):
        for column, j in enumerate(order):
            panel = axes[row, column]
            if column > row:
                panel.axis("off")
                continue
            first, second = result.parameters[j], result.parameters[i]
            if row == column:
                panel.hist(result.samples[:, i], bins=_bins(first), weights=weights, color="#3b75af", alpha=0.7)
                panel.set_yticks([])
            else:
                panel.hist2d(
                    result.samples[:, j],
                    result.samples[:, i],
                    bins=[_bins(first, 20), _bins(second, 20)],
                    weights=weights,
                    cmap="Blues",
                )
                panel.set_ylim(*_axis_limits(second))
                ticks, labels = _tick_labels(second)
                panel.set_yticks(ticks, labels if column == 0 else [], fontsize=7)
            panel.set_xlim(*_axis_limits(first))
            ticks, labels = _tick_labels(first)
            panel.set_xticks(
                ticks, labels if row == count - 1 else [], fontsize=7, rotation=30 if first.kind == "categorical" else 0
            )
            if row == count - 1:
                panel.set_xlabel(first.name, fontsize=8)
            if column == 0 and row > 0:
                panel.set_ylabel(second.name, fontsize=8)
    figure.suptitle(f"{result.method} posterior, pairs of the {count} highest-ranked parameters", fontsize=10)
    figure.tight_layout()
    return _save(figure, out_stem)


def _save(figure: Any, out_stem: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = [out_stem.with_suffix(".png"), out_stem.with_suffix(".svg")]
    figure.savefig(paths[0], dpi=90)
    with plt.rc_context({"svg.hashsalt": "robolab-sensitivity"}):  # fixed ids and no date: the same analysis
        figure.savefig(paths[1], metadata={"Date": None})  # writes the same file
    plt.close(figure)
    return paths


def write_outputs(result: SensitivityResult, out_dir: Path, pairs: int = 6) -> list[Path]:
    """The ranking (CSV, Markdown), the posterior samples (CSV, normalised scale, with weights) and the plots."""
    import pandas as pd

    make_folder(out_dir, "--out")
    result.table.to_csv(out_dir / TABLE_CSV, index=False, float_format="%.6g")
    (out_dir / TABLE_MD).write_text(to_markdown(result), encoding="utf-8")
    samples = pd.DataFrame(result.samples, columns=[p.name for p in result.parameters])
    samples["weight"] = result.weights if result.weights is not None else 1.0 / len(samples)
    samples.to_csv(out_dir / SAMPLES_CSV, index=False, float_format="%.6g")
    paths = [out_dir / TABLE_CSV, out_dir / TABLE_MD, out_dir / SAMPLES_CSV]
    paths += plot_marginals(result, out_dir / MARGINALS)
    paths += plot_pairs(result, out_dir / PAIRS, pairs)
    return paths


# ---------------------------------------------------------------------------------------------------------- command


def add_arguments(parser: Any) -> None:
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR", help="results folders of `robolab eval --vary ...`")
    parser.add_argument(
        "--params",
        nargs="+",
        metavar="NAME",
        help="parameters to analyse, comma- or space-separated (default: every recorded variation "
        "field with more than one value; cameras as cam_<camera>_dist)",
    )
    parser.add_argument(
        "--obs",
        nargs="+",
        default=["success"],
        metavar="NAME",
        help="outcomes: success, duration (seconds), score, progress, steps or any numeric column (default: success)",
    )
    parser.add_argument(
        "--at",
        nargs="+",
        metavar="OBS=VALUE",
        help="the outcome to explain, e.g. success=0 (default: success=1; other outcomes at their "
        "median over the matching episodes)",
    )
    parser.add_argument("--policy", help="the policy to analyse when the folders hold several")
    parser.add_argument("--task", nargs="+", metavar="TASK", help="only these tasks' episodes")
    parser.add_argument("--epochs", type=int, default=50, help="most training epochs (default 50, as RoboLab)")
    parser.add_argument("--samples", type=int, default=5000, help="posterior samples (default 5000)")
    parser.add_argument("--batch-size", type=int, default=200, help="training batch size (default 200, sbi's)")
    parser.add_argument(
        "--beta",
        type=float,
        default=1.0,
        help="metres per radian in the camera distance ||dt|| + beta x angle (default 1)",
    )
    parser.add_argument(
        "--reweight",
        action="store_true",
        help="importance-weight the samples to the uniform prior (Gaussian KDE of the drawn "
        "parameters) and report the effective sample size",
    )
    parser.add_argument("--pairs", type=int, default=6, help="parameters in the pairwise plot (default 6)")
    parser.add_argument(
        "--null",
        type=int,
        default=0,
        metavar="K",
        help="K more fits on outcomes shuffled across episodes, for each parameter's chance level "
        "of shift (default 0; each costs one fit)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of training and sampling (default 0)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads for the fit (default 1)")
    parser.add_argument("--out", help="folder for the table, samples and plots (default: RUN_DIR/sensitivity)")


def run(args: Any) -> int:
    """`robolab sensitivity`: fit, print the ranking as Markdown, write the files."""
    from robolab_ms.analysis.runs import load_runs

    if args.pairs < 1 or args.threads < 1:
        raise RoboLabError(f"--pairs {args.pairs}, --threads {args.threads}: give at least 1")
    runs = load_runs(args.runs)
    out_dir = make_folder(Path(args.out) if args.out else Path(args.runs[0]) / "sensitivity", "--out")
    result = analyse(
        runs,
        args.params,
        args.obs,
        parse_at(args.at),
        args.epochs,
        args.samples,
        args.seed,
        args.beta,
        args.reweight,
        args.policy,
        args.task,
        args.batch_size,
        args.threads,
        args.null,
    )
    paths = write_outputs(result, out_dir, args.pairs)
    print(to_markdown(result, timing=True), end="")
    print(f"\nwrote {', '.join(str(p) for p in paths)}")
    return 0
