"""`robolab sensitivity`: RoboLab's sbi analysis ranks the parameter that drives success first, the camera pose
reduction, reweighting, reproducibility and the errors a user can act on."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from robolab_ms.analysis.runs import load_runs, task_table
from robolab_ms.analysis.sensitivity import (
    analyse,
    camera_distance,
    kde_density,
    prepare,
    rotation_angle,
    to_markdown,
)
from robolab_ms.analysis.synthetic import LIGHT_SPACE, light_dependent_success, write_synthetic_run
from robolab_ms.cli import main as robolab
from robolab_ms.errors import RoboLabError

TASK = "BananaInBowl"
CAMERA_SPACE = {"light_intensity": (0.05, 3.0), "cam_wrist_dx": (-0.015, 0.015), "cam_wrist_dy": (-0.015, 0.015),
                "cam_wrist_dz": (-0.01, 0.01), "cam_wrist_droll": (-0.05, 0.05), "cam_wrist_dpitch": (-0.05, 0.05),
                "cam_wrist_dyaw": (-0.05, 0.05)}  # fmt: skip


@pytest.fixture(scope="module")
def task_info():
    return task_table([TASK])


@pytest.fixture(scope="module")
def small_light_run(tmp_path_factory, task_info):
    """40 episodes whose success depends on the light's intensity: enough to fit, too few to learn much."""
    out = write_synthetic_run(
        tmp_path_factory.mktemp("light") / "run", "p", [TASK], 40, light_dependent_success, params=LIGHT_SPACE
    )
    return load_runs([out], task_info=task_info)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0])
def test_light_intensity_ranks_above_camera_and_colour(tmp_path, capsys, seed):
    """Success depends on light_intensity only (synthetic.light_dependent_success): the command must rank it above
    cam_external_left_dx and light_color, with its posterior moved toward bright light."""
    run = write_synthetic_run(
        tmp_path / "run", "p", [TASK], 300, light_dependent_success, seed=seed, params=LIGHT_SPACE
    )
    out = tmp_path / "sensitivity"
    code = robolab(
        [
            "sensitivity",
            str(run),
            "--epochs",
            "30",
            "--batch-size",
            "50",
            "--samples",
            "2000",
            "--seed",
            str(seed),
            "--out",
            str(out),
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    table = pd.read_csv(out / "sensitivity.csv")
    assert list(table["parameter"])[0] == "light_intensity", table
    shift = dict(zip(table["parameter"], table["shift"]))
    assert shift["light_intensity"] > shift["cam_external_left_dx"]
    assert shift["light_intensity"] > shift["light_color"]
    light = table.set_index("parameter").loc["light_intensity"]
    # true posterior at success = 1: density 0.05 + 0.9 t on [0, 1], mean 0.65, KS distance to uniform 0.225
    assert light["posterior_mean"] > light["prior_mean"] + 0.05 and light["range_source"] == "manifest"
    assert "| 1 | light_intensity |" in printed and "MNPE" in printed
    for name in (
        "sensitivity.md",
        "posterior_samples.csv",
        "sensitivity_marginals.png",
        "sensitivity_marginals.svg",
        "sensitivity_pairs.png",
        "sensitivity_pairs.svg",
    ):
        assert (out / name).stat().st_size > 0, name
    samples = pd.read_csv(out / "posterior_samples.csv")
    assert len(samples) == 2000 and samples["light_color"].isin(range(6)).all()


def test_same_seed_gives_the_same_numbers(small_light_run):
    first = analyse(small_light_run, epochs=2, samples=300, seed=3)
    again = analyse(small_light_run, epochs=2, samples=300, seed=3)
    other = analyse(small_light_run, epochs=2, samples=300, seed=4)
    pd.testing.assert_frame_equal(first.table, again.table)
    assert np.array_equal(first.samples, again.samples) and not np.array_equal(first.samples, other.samples)


def test_reweighting_reports_the_effective_sample_size(small_light_run):
    result = analyse(small_light_run, epochs=2, samples=400, seed=0, reweight=True)
    assert result.weights is not None and math.isclose(result.weights.sum(), 1.0)
    assert 1.0 <= result.effective_sample_size <= 400
    assert f"effective sample size {result.effective_sample_size:.0f} of 400" in to_markdown(result)


def test_kde_of_uniform_draws_is_flat_up_to_the_edges():
    """Reflected at 0 and 1: without it the density of uniform draws would halve at an edge and quarter at a corner."""
    data = np.random.default_rng(0).uniform(0, 1, (20000, 2))
    grid = np.array([[a, b] for a in (0.0, 0.02, 0.5, 0.98, 1.0) for b in (0.0, 0.5, 1.0)])
    assert np.allclose(kde_density(grid, data), 1.0, atol=0.25)


def test_all_categorical_parameters_fit_with_mnpe(small_light_run):
    result = analyse(small_light_run, params=["light_color"], epochs=2, samples=200, seed=0)
    assert result.method == "MNPE" and list(result.table["parameter"]) == ["light_color"]
    assert result.samples.shape == (200, 1) and any("categorical" in note for note in result.notes)


def test_camera_distance_of_known_poses():
    poses = np.array(
        [
            [0.1, 0.0, 0.0, 0.0, 0.0, 0.0],  # 10 cm along x
            [0.03, 0.04, 0.0, 0.0, 0.0, 0.0],  # 3-4-5 triangle
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.2],  # yaw 0.2 rad
            [0.0, 0.0, 0.0, -0.15, 0.0, 0.0],  # roll -0.15 rad
            [0.0, 0.0, 0.1, 0.0, 0.0, 0.0],
        ]
    )
    assert np.allclose(camera_distance(poses), [0.1, 0.05, 0.2, 0.15, 0.1])
    assert np.allclose(camera_distance(poses, beta=2.0), [0.1, 0.05, 0.4, 0.3, 0.1])
    # roll then pitch about perpendicular axes: quaternion w = cos(0.05)^2, one turn of 2 acos(w), not 0.2
    assert math.isclose(float(rotation_angle(0.1, 0.1, 0.0)), 2 * math.acos(math.cos(0.05) ** 2), rel_tol=1e-9)


def test_camera_angle_matches_how_variations_turn_the_camera():
    """The angle between the nominal and the moved camera, as robolab_ms.variations.camera.offset_pose applies the
    offsets to a tilted camera, is the angle of the reduction."""
    import sapien
    from transforms3d.quaternions import qinverse, qmult

    from robolab_ms.variations.camera import offset_pose

    nominal = sapien.Pose(p=[0.1, 0.5, 0.6], q=[0.8536, 0.1464, 0.3536, -0.3536])
    rng = np.random.default_rng(1)
    for _ in range(5):
        roll, pitch, yaw = rng.uniform(-0.4, 0.4, 3)
        moved = offset_pose(nominal, [0.0, 0.0, 0.0, roll, pitch, yaw])
        q = qmult(qinverse(np.asarray(nominal.q, dtype=float)), np.asarray(moved.raw_pose[0, 3:], dtype=float))
        angle = 2 * math.atan2(np.linalg.norm(q[1:]), abs(q[0]))
        assert math.isclose(float(rotation_angle(roll, pitch, yaw)), angle, abs_tol=1e-5)


def test_camera_offsets_become_one_distance_per_camera(tmp_path, task_info):
    run = write_synthetic_run(tmp_path / "run", "p", [TASK], 30, 0.5, params=CAMERA_SPACE)
    runs = load_runs([run], task_info=task_info)
    inputs = prepare(runs)
    names = [p.name for p in inputs.parameters]
    assert sorted(names) == ["cam_wrist_dist", "light_intensity"]
    column = names.index("cam_wrist_dist")
    offsets = runs.episodes[[f"cam_wrist_{o}" for o in ("dx", "dy", "dz", "droll", "dpitch", "dyaw")]].to_numpy()
    distance = camera_distance(offsets)
    expected = (distance - distance.min()) / (distance.max() - distance.min())
    assert np.allclose(inputs.theta[:, column], expected)


def test_unknown_parameter_lists_the_available_ones(small_light_run, capsys):
    with pytest.raises(RoboLabError, match="not a varied parameter") as error:
        prepare(small_light_run, params=["light_intensty"])
    assert "Did you mean 'light_intensity'" in str(error.value)
    assert "Available: " in str(error.value) and "cam_external_left_dx" in str(error.value)
    folder = str(small_light_run.folders[0])
    assert robolab(["sensitivity", folder, "--params", "nothing_like_it"]) == 2
    message = capsys.readouterr().err
    assert message.startswith("robolab: error: --params: 'nothing_like_it'") and "light_color" in message


def test_run_without_variations_says_to_vary(tmp_path, task_info):
    run = write_synthetic_run(tmp_path / "plain", "p", [TASK], 30, 0.5)
    with pytest.raises(RoboLabError, match=r"no drawn variation parameters.*--vary lighting"):
        prepare(load_runs([run], task_info=task_info))


def test_outcomes_that_cannot_be_analysed_are_refused(tmp_path, task_info, small_light_run):
    always = write_synthetic_run(tmp_path / "always", "p", [TASK], 30, 1.0, params=LIGHT_SPACE)
    with pytest.raises(RoboLabError, match="'success' is 1 in every episode.*--obs duration"):
        prepare(load_runs([always], task_info=task_info))
    with pytest.raises(RoboLabError, match="'speed' is not an outcome.*Available: success, duration"):
        prepare(small_light_run, observations=["speed"])
    with pytest.raises(RoboLabError, match="not among --obs"):
        analyse(small_light_run, at={"duration": 5.0})
    other = write_synthetic_run(tmp_path / "other", "q", [TASK], 30, 0.5, params=LIGHT_SPACE)
    with pytest.raises(RoboLabError, match="choose it with --policy"):
        prepare(load_runs([small_light_run.folders[0], other], task_info=task_info))
