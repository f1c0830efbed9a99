"""Cameras: DROID's poses and fields of view, the wrist camera riding on the gripper, resolution, the video view."""

import math

import gymnasium as gym
import numpy as np
import pytest

from robolab_ms.envs import RoboLabEnv
from robolab_ms.errors import UnknownNameError


def params(env, name):
    p = env.unwrapped.scene.sensors[name].get_params()
    return p["extrinsic_cv"][0].numpy(), p["intrinsic_cv"][0].numpy()


def project(env, name, point):
    """Pixel (u, v) of a world point in camera `name`, and its depth."""
    extrinsic, intrinsic = params(env, name)
    cam = extrinsic[:, :3] @ np.asarray(point) + extrinsic[:, 3]
    u, v, w = intrinsic @ cam
    return u / w, v / w, cam[2]


def horizontal_fov_deg(env, name):
    _, intrinsic = params(env, name)
    return math.degrees(2 * math.atan(env.unwrapped.camera_width / 2 / intrinsic[0, 0]))


def in_image(env, uvz, rows=(0.0, 1.0)):
    u, v, z = uvz
    width, height = env.unwrapped.camera_width, env.unwrapped.camera_height
    return z > 0 and 0 <= u < width and rows[0] * height <= v < rows[1] * height


def test_fields_of_view_are_droids(banana_env):
    banana_env.reset(seed=0)
    assert horizontal_fov_deg(banana_env, "external_left") == pytest.approx(104.0, abs=0.2)
    assert horizontal_fov_deg(banana_env, "wrist") == pytest.approx(87.7, abs=0.2)


def test_external_camera_sees_table_objects_and_gripper(banana_env):
    banana_env.reset(seed=0)
    base = banana_env.unwrapped
    extrinsic, _ = params(banana_env, "external_left")
    position = -extrinsic[:, :3].T @ extrinsic[:, 3]
    np.testing.assert_allclose(position, [0.05, 0.57, 0.66], atol=1e-3)
    points = [(0.55, 0.0, 0.0), base.agent.tcp.pose.p[0].tolist()]
    points += [actor.pose.p[0].tolist() for actor in base.objects.values()]
    for point in points:
        assert in_image(banana_env, project(banana_env, "external_left", point)), point


def test_wrist_camera_rides_on_the_gripper_and_sees_the_fingers_below(banana_env):
    banana_env.reset(seed=0)
    base = banana_env.unwrapped
    pads = [link.pose.p[0].tolist() for link in base.eval_context.finger_links[:2]]
    for pad in pads:  # the fingers show in the lower half, as in DROID's wrist images
        assert in_image(banana_env, project(banana_env, "wrist", pad), rows=(0.5, 1.0)), pad
    assert in_image(banana_env, project(banana_env, "wrist", (0.55, 0.0, 0.0)))
    before, _ = params(banana_env, "wrist")
    arm = base.arm_qpos()[0].numpy() + [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    for _ in range(10):
        banana_env.step(np.array([*arm, 0.0], dtype=np.float32))
    after, _ = params(banana_env, "wrist")
    assert not np.allclose(before, after, atol=1e-3)
    for pad in [link.pose.p[0].tolist() for link in base.eval_context.finger_links[:2]]:
        assert in_image(banana_env, project(banana_env, "wrist", pad), rows=(0.5, 1.0))


def test_right_camera_mirrors_the_left():
    env = RoboLabEnv(
        task="BananaInBowl",
        obs_mode="rgb",
        render_backend="cpu",
        render_mode="rgb_array",
        cameras=("external_right",),
        camera_width=640,
        camera_height=360,
        video_width=320,
        video_height=240,
    )
    obs, _ = env.reset(seed=0)
    try:
        assert tuple(obs["sensor_data"]["external_right"]["rgb"].shape) == (1, 360, 640, 3)
        assert set(obs["sensor_data"]) == {"external_right"}
        extrinsic, _ = params(env, "external_right")
        np.testing.assert_allclose(-extrinsic[:, :3].T @ extrinsic[:, 3], [0.05, -0.57, 0.66], atol=1e-3)
        assert in_image(env, project(env, "external_right", (0.55, 0.0, 0.0)))
        assert horizontal_fov_deg(env, "external_right") == pytest.approx(104.0, abs=0.2)
        video = env.render()
        assert tuple(video.shape) == (1, 240, 320, 3) and video.float().std() > 5.0
    finally:
        env.close()


@pytest.mark.parametrize(
    "kwargs, error",
    [
        (dict(cameras=("external_left", "top")), UnknownNameError),
        (dict(camera_width=1920, camera_height=1080), ValueError),
    ],
)
def test_bad_camera_requests_are_refused(kwargs, error):
    with pytest.raises(error):
        gym.make("RoboLab-BananaInBowl-v1", obs_mode="rgb", render_backend="cpu", **kwargs)
