"""Glasses drawn over real frames on a real EGL context: placement, compositing, occlusion."""

from __future__ import annotations

import cv2
import moderngl
import numpy as np
import pytest
from scipy.ndimage import binary_dilation

from aamcore.ar.glasses_mesh import OPAQUE_PARTS
from aamcore.ar.projection import project_points
from aamcore.ar.renderer import GlassesRenderer
from aamcore.pose.head_model import openface68

W, H = 640, 480
K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])
T = np.array([5.0, -10.0, 600.0])


def _yaw(degrees: float) -> np.ndarray:
    return cv2.Rodrigues(np.array([0.0, np.radians(degrees), 0.0]))[0]


@pytest.fixture(scope="module")
def renderer(gl_ctx: moderngl.Context) -> GlassesRenderer:
    r = GlassesRenderer(W, H, gl_ctx, samples=0)
    yield r
    r.release()


@pytest.fixture(scope="module")
def frame(imm_set) -> np.ndarray:
    return cv2.resize(imm_set.samples[0].load_image(), (W, H))


def _eye_pixels(R: np.ndarray) -> np.ndarray:
    """Projected centres (2, 2) of the right (iBUG 36-41) and left (42-47) eyes."""
    head = openface68().points
    eyes = np.array([head[36:42].mean(axis=0), head[42:48].mean(axis=0)])
    return project_points(eyes, R, T, K)


def test_lenses_land_over_the_eyes(renderer: GlassesRenderer, frame: np.ndarray) -> None:
    R = np.eye(3)
    before = frame.copy()
    out = renderer.render(frame, R, T, K)
    np.testing.assert_array_equal(frame, before)  # the input is left alone
    for side, (x, y) in zip(("right", "left"), _eye_pixels(R), strict=True):
        col, row = round(x), round(y)
        assert renderer.coverage(R, T, K, [f"lens_{side}"])[row, col], side
        rim = np.flatnonzero(renderer.coverage(R, T, K, [f"rim_{side}"])[row])
        assert rim.min() < col < rim.max(), f"the {side} rim does not surround the eye"
        # the lens tints the eye blue-grey without hiding it
        change = out[row, col].astype(int) - frame[row, col].astype(int)
        assert np.abs(change).max() > 5 and change[0] > change[2], side
        assert np.abs(change).max() < 120, side


def test_the_frame_shows_where_the_glasses_are_not(renderer, frame) -> None:
    R = _yaw(20.0)
    out = renderer.render(frame, R, T, K)
    drawn = binary_dilation(renderer.coverage(R, T, K), iterations=2)
    assert 0.01 < drawn.mean() < 0.2
    np.testing.assert_array_equal(out[~drawn], frame[~drawn])
    changed = np.any(out != frame, axis=2)
    assert changed[drawn].mean() > 0.5


def test_a_temple_behind_the_turned_head_is_hidden(renderer: GlassesRenderer) -> None:
    R = _yaw(60.0)
    glasses = renderer.glasses
    depth = {
        name: float((glasses.part_vertices(name) @ R.T + T)[:, 2].mean())
        for name in ("temple_right", "temple_left")
    }
    far, near = sorted(depth, key=depth.get, reverse=True)
    for name, bound in ((far, None), (near, 0.95)):
        seen = renderer.coverage(R, T, K, [name]).sum()
        unhidden = renderer.coverage(R, T, K, [name], occlude=False).sum()
        assert unhidden > 100, name
        if bound is None:
            assert seen < 0.5 * unhidden, f"far temple {name}: {seen} of {unhidden} px visible"
        else:
            assert seen >= bound * unhidden, f"near temple {name}: {seen} of {unhidden} px"
    # seen from the front, the head hides little of the frame and nothing of the lenses
    front = renderer.coverage(np.eye(3), T, K, OPAQUE_PARTS).sum()
    assert front > 0.8 * renderer.coverage(np.eye(3), T, K, OPAQUE_PARTS, occlude=False).sum()


def test_multisampled_render_matches(gl_ctx: moderngl.Context, renderer, frame) -> None:
    smooth = GlassesRenderer(W, H, gl_ctx, glasses=renderer.glasses, head=renderer.head, samples=4)
    try:
        R = _yaw(-25.0)
        a, b = smooth.render(frame, R, T, K), renderer.render(frame, R, T, K)
        diff = np.abs(a.astype(int) - b.astype(int))
        assert diff.mean() < 1.0
        assert smooth.samples == 0 or np.any(diff > 0)  # edges were smoothed
    finally:
        smooth.release()


def test_bad_input_is_refused(renderer: GlassesRenderer, frame: np.ndarray) -> None:
    with pytest.raises(ValueError, match=r"\(480, 640, 3\)"):
        renderer.render(frame[:100], np.eye(3), T, K)
    with pytest.raises(ValueError, match="uint8"):
        renderer.render(frame.astype(np.float32), np.eye(3), T, K)
    with pytest.raises(ValueError, match="rotation"):
        renderer.render(frame, 2 * np.eye(3), T, K)
    with pytest.raises(ValueError, match="unknown glasses parts"):
        renderer.coverage(np.eye(3), T, K, ["monocle"])
