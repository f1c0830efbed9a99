"""Geometry helpers of the evaluation context."""

import torch


def test_quaternion_to_matrix_matches_scipy():
    from scipy.spatial.transform import Rotation

    from robolab_ms.tasks.context import quaternion_to_matrix

    rotations = Rotation.random(50, random_state=0)
    xyzw = rotations.as_quat()
    wxyz = torch.tensor(xyzw[:, [3, 0, 1, 2]], dtype=torch.float32)
    expected = torch.tensor(rotations.as_matrix(), dtype=torch.float32)
    assert torch.allclose(quaternion_to_matrix(wxyz), expected, atol=1e-5)
