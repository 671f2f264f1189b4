"""A hand in front of the face hides the glasses: the covered pixels, and the overlay stage
drawing real glasses on a real EGL context with and without them."""

from __future__ import annotations

import cv2
import moderngl
import numpy as np
import pytest

from aamcore.ar.cover import COVER_MM, cover_mask, cover_radius, covered_points
from aamcore.ar.projection import project_points
from aamcore.operators.faces import FacePose
from aamcore.operators.options import OverlayOptions
from aamcore.operators.overlay import OverlayOperator
from aamcore.pose.head_model import openface68

W, H = 640, 480
K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])
T = np.array([5.0, -10.0, 600.0])
HEAD = openface68().points
LANDMARKS = project_points(HEAD, np.eye(3), T, K)
"""The head model's 68 landmarks seen frontally at 600 mm: where a fit would put them."""
RIGHT_EYE = np.r_[17:22, 36:42]
"""The right brow and eye (iBUG numbering): what a hand over that eye covers."""


def test_the_covered_points_are_the_flagged_ones_and_only_with_flags_for_them() -> None:
    points = np.arange(10.0).reshape(5, 2)
    flags = np.array([True, False, False, True, False])
    np.testing.assert_array_equal(covered_points(points, flags), points[[0, 3]])
    assert covered_points(points, None) is None
    assert covered_points(points, np.ones(4, bool)) is None
    assert covered_points(points, np.zeros(5, bool)).shape == (0, 2)


def test_the_band_is_the_millimetres_at_the_head_s_depth() -> None:
    assert cover_radius(K, T) == pytest.approx(800.0 * COVER_MM / 600.0)
    assert cover_radius(K, T * 2) == pytest.approx(cover_radius(K, T) / 2)


def test_a_cluster_of_covered_landmarks_covers_them_and_between_them() -> None:
    pts = LANDMARKS[RIGHT_EYE]
    radius = cover_radius(K, T)
    mask = cover_mask(pts, (H, W), radius)
    assert mask is not None and mask.shape == (H, W)
    ij = np.round(pts).astype(int)
    assert mask[ij[:, 1], ij[:, 0]].all()
    between = np.round((pts[0] + pts[-1]) / 2).astype(int)  # brow to eye: one piece
    assert mask[between[1], between[0]]
    far = np.round(LANDMARKS[45]).astype(int)  # the other eye stays clear
    assert not mask[far[1], far[0]]
    # the band's width follows the radius
    assert cover_mask(pts, (H, W), 2 * radius).sum() > 1.5 * mask.sum()


def test_scattered_flags_hide_nothing() -> None:
    """The occlusion test flags a few visible landmarks in every frame: one here and there
    must not punch holes in the glasses."""
    radius = cover_radius(K, T)
    assert cover_mask(LANDMARKS[[8, 36, 45]], (H, W), radius) is None
    assert cover_mask(LANDMARKS[[36, 37]], (H, W), radius) is None
    assert cover_mask(np.zeros((0, 2)), (H, W), radius) is None
    assert cover_mask(LANDMARKS[RIGHT_EYE], (H, W), radius=0.0) is None


@pytest.fixture(scope="module")
def overlay(gl_ctx: moderngl.Context) -> OverlayOperator:
    op = OverlayOperator(ctx=gl_ctx)
    yield op
    op.close()


@pytest.fixture(scope="module")
def frame(imm_set) -> np.ndarray:
    return cv2.resize(imm_set.samples[0].load_image(), (W, H))


def _pose(covered: np.ndarray | None) -> FacePose:
    return FacePose(0, np.eye(3), T, (0.0, 0.0, 0.0), K, True, covered=covered)


def test_a_hand_over_an_eye_hides_that_lens_and_leaves_the_other(overlay, frame) -> None:
    plain = overlay(frame, [_pose(None)])
    covered = overlay(frame, [_pose(LANDMARKS[RIGHT_EYE])])
    mask = overlay.covered(_pose(LANDMARKS[RIGHT_EYE]), (H, W))
    assert mask is not None
    drawn = np.any(plain != frame, axis=2)
    assert drawn[mask].mean() > 0.3  # the glasses were there, under the hand
    np.testing.assert_array_equal(covered[mask], frame[mask])  # the hand shows through
    np.testing.assert_array_equal(covered[~mask], plain[~mask])  # the rest is drawn as ever
    right, left = (np.round(LANDMARKS[i:i + 6].mean(axis=0)).astype(int) for i in (36, 42))
    assert mask[right[1], right[0]] and not mask[left[1], left[0]]
    assert np.any(covered[left[1], left[0]] != frame[left[1], left[0]])  # the left lens


def test_the_options_can_draw_the_glasses_over_the_hand(gl_ctx, frame) -> None:
    op = OverlayOperator(OverlayOptions(hide_covered=False), ctx=gl_ctx)
    try:
        pose = _pose(LANDMARKS[RIGHT_EYE])
        assert op.covered(pose, (H, W)) is None
        np.testing.assert_array_equal(op(frame, [pose]), op(frame, [_pose(None)]))
    finally:
        op.close()
