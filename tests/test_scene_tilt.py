"""The scene field `tilt`: an object laid on its side rests on the table; mistakes name the file, field and fix."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolab_ms.catalog.procedural import quat_multiply, yaw_quat
from robolab_ms.errors import SpecError
from robolab_ms.scene import IDENTITY_QUAT, read_scene, resting_height

SCENE = """
name: s
objects:
  - {{name: mug, asset: mug_red, xy: [0.5, 0.1]{extra}}}
"""


def scene_file(tmp_path, extra: str):
    path = tmp_path / "s.yaml"
    path.write_text(SCENE.format(extra=extra))
    return path


def test_tilt_is_read_as_a_quarter_turn_about_the_object_axis(tmp_path):
    upright = read_scene(scene_file(tmp_path, "")).objects[0]
    assert upright.tilt == IDENTITY_QUAT
    lying = read_scene(scene_file(tmp_path, ", tilt: {axis: y, deg: 90}")).objects[0]
    assert np.allclose(lying.tilt, (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0))


@pytest.mark.parametrize(
    ("extra", "field", "hint"),
    [
        (", tilt: {axis: z, deg: 90}", "objects[0].tilt.axis", "is not one of x, y"),
        (", tilt: {axis: x, deg: 270}", "objects[0].tilt.deg", "in degrees"),
        (", tilt: {axis: x, degrees: 90}", "objects[0].tilt.degrees", "Did you mean 'deg'"),
        (", tilt: 90", "objects[0].tilt", "tilt: {axis: x, deg: 90}"),
    ],
)
def test_bad_tilt_names_file_field_and_fix(tmp_path, extra, field, hint):
    path = scene_file(tmp_path, extra)
    with pytest.raises(SpecError) as error:
        read_scene(path)
    message = str(error.value)
    assert str(path) in message and field in message and hint in message


def test_resting_height_puts_the_lowest_turned_point_on_the_table():
    # a 0.10 x 0.04 x 0.02 m box with its origin at the centre of its bottom face
    corners = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.02, 0.02) for z in (0.0, 0.02)])
    assert resting_height(corners, IDENTITY_QUAT) == pytest.approx(0.0)
    on_end = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)  # 90 deg about y: x points down
    assert resting_height(corners, on_end) == pytest.approx(0.05)
    turned = quat_multiply(yaw_quat(1.0), on_end)  # a yaw about the world z keeps the height
    assert resting_height(corners, turned) == pytest.approx(0.05)


def test_lying_mug_rests_on_its_side_on_the_table():
    from helpers import FIXTURES

    from robolab_ms.envs import RoboLabEnv

    env = RoboLabEnv(task=str(FIXTURES / "LyingMug.yaml"), obs_mode="state_dict", render_backend="cpu")
    try:
        env.reset(seed=0)
        ctx = env.unwrapped.eval_context
        ctx.refresh()
        up = ctx.rotation("red_mug")[0, :, 2]
        assert abs(float(up[2])) < 0.05  # its axis lies flat
        points = (
            ctx.entries["red_mug"].points @ ctx.rotation("red_mug")[0].numpy().T + ctx.position("red_mug")[0].numpy()
        )
        assert 0.0 <= points[:, 2].min() <= 0.004
    finally:
        env.close()


def test_upside_down_mug_rests_on_its_rim():
    import gymnasium as gym

    env = gym.make("RoboLab-ReorientRedMug-v1", obs_mode="state_dict", render_backend="cpu")  # as in RoboLab's scene
    try:
        env.reset(seed=0)
        ctx = env.unwrapped.eval_context
        ctx.refresh()
        assert float(ctx.rotation("red_mug")[0, 2, 2]) < -0.95  # its axis points down
        points = (
            ctx.entries["red_mug"].points @ ctx.rotation("red_mug")[0].numpy().T + ctx.position("red_mug")[0].numpy()
        )
        assert 0.0 <= points[:, 2].min() <= 0.004
    finally:
        env.close()
