"""aamcore.pose.visibility: landmark normals of the head model and the visibility ramp."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import openface68
from aamcore.pose.rotation import rotation_from_rpy
from aamcore.pose.visibility import landmark_normals, visibility_weights

T = np.array([0.0, 0.0, 600.0])


def test_normals_are_unit_and_face_the_camera_frontally() -> None:
    n = landmark_normals(openface68())
    assert n.shape == (68, 3)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert n[30, 2] < -0.8  # the nose tip looks at the camera
    assert n[0, 0] < -0.3 and n[16, 0] > 0.3  # the jaw ends turn outward


def test_far_side_eye_corner_fades_as_the_head_turns() -> None:
    model = openface68()
    n = landmark_normals(model)
    frontal = visibility_weights(model.points, n, np.eye(3), T)
    assert frontal[[36, 39, 42, 45, 30]].min() == 1.0
    # At yaw +80 the subject's right (image left, point 36) turns away.
    turned = visibility_weights(model.points, n, rotation_from_rpy(0, 0, 80.0), T)
    assert turned[36] < 0.5 and turned[45] == 1.0
    assert np.all((turned >= 0) & (turned <= 1))


def test_a_partial_model_has_no_normals() -> None:
    with pytest.raises(PoseError, match="full iBUG-68"):
        landmark_normals(openface68(rigid_subset="no_jaw"))
