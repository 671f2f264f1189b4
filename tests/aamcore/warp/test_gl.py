"""The OpenGL warp against the CPU warp, on a real EGL context and real IMM images."""

from __future__ import annotations

import cv2
import moderngl
import numpy as np
import pytest

from aamcore.warp.gl import GLWarp, grown_triangle_weights
from aamcore.warp.piecewise_affine import PiecewiseAffineWarp
from aamcore.warp.reference_frame import ReferenceFrame

# Tolerances: the GL texture unit weights with 8-bit fractions, cv2.remap with
# 5-bit ones; measured on IMM: max 2, mean 0.17-0.19 grey levels.
MAX_DIFF = 3.0
MEAN_DIFF = 0.5
FRACTION_OVER_ONE = 0.01


@pytest.fixture(scope="module")
def gl_warp(gl_ctx: moderngl.Context, imm_model) -> GLWarp:
    warp = GLWarp(imm_model.frame, imm_model.shape.n_points, gl_ctx)
    yield warp
    warp.release()


@pytest.fixture(scope="module")
def held_out(imm_set) -> list:
    samples = [s for s in imm_set.samples if int(s.subject) >= 10]
    return samples[::7][:4]


def _agreement(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    diff = np.abs(a - b)
    return float(diff.max()), float(diff.mean()), float(np.mean(diff > 1.0))


@pytest.mark.parametrize("grey", [False, True], ids=["bgr", "grey"])
def test_gl_warp_agrees_with_cpu_warp(gl_warp: GLWarp, imm_model, held_out, grey: bool) -> None:
    for sample in held_out:
        image = sample.load_image()
        if grey:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        cpu = imm_model.warp.warp(image, sample.points)
        gpu = gl_warp.warp_image(image, sample.points)
        assert gpu.shape == cpu.shape and gpu.dtype == np.float32
        worst, mean, over = _agreement(gpu, cpu)
        assert worst <= MAX_DIFF, f"{sample.image_path.name}: max diff {worst}"
        assert mean < MEAN_DIFF, f"{sample.image_path.name}: mean diff {mean}"
        assert over < FRACTION_OVER_ONE, f"{sample.image_path.name}: {over:.2%} over 1 grey level"


def test_one_upload_serves_many_shapes(gl_warp: GLWarp, imm_model, held_out) -> None:
    sample = held_out[0]
    image = sample.load_image()
    gl_warp.upload(image)
    texture = gl_warp._texture
    rng = np.random.default_rng(1)
    for _ in range(3):
        shape = sample.points + rng.normal(0, 3, sample.points.shape)
        assert _agreement(gl_warp.warp(shape), imm_model.warp.warp(image, shape))[1] < MEAN_DIFF
    gl_warp.upload(image[::-1].copy())  # same size: the texture object is reused
    assert gl_warp._texture is texture
    gl_warp.upload(image[:300])
    assert gl_warp._texture is not texture


def test_landmarks_outside_the_image_repeat_the_border(gl_warp: GLWarp, imm_model, held_out):
    image = held_out[1].load_image()
    shape = held_out[1].points + [-image.shape[1] * 0.4, 0.0]  # half the face off the left edge
    worst, mean, _ = _agreement(gl_warp.warp_image(image, shape), imm_model.warp.warp(image, shape))
    assert worst <= MAX_DIFF and mean < MEAN_DIFF


def test_bad_input_is_refused(gl_ctx: moderngl.Context, imm_model, held_out) -> None:
    warp = GLWarp(imm_model.frame, imm_model.shape.n_points, gl_ctx)
    try:
        with pytest.raises(RuntimeError, match="no image uploaded"):
            warp.warp(held_out[0].points)
        image = held_out[0].load_image()
        with pytest.raises(ValueError, match="uint8"):
            warp.upload(image.astype(np.float32))
        with pytest.raises(ValueError, match="grey"):
            warp.upload(np.zeros((10, 10, 4), np.uint8))
        warp.upload(image)
        with pytest.raises(ValueError, match=r"shape must be \(73, 2\)"):
            warp.warp(held_out[0].points[:10])
        bad = held_out[0].points.copy()
        bad[3, 0] = np.nan
        with pytest.raises(ValueError, match="NaN"):
            warp.warp(bad)
    finally:
        warp.release()
    with pytest.raises(ValueError, match="n_points"):
        GLWarp(imm_model.frame, 10, gl_ctx)


def _square_frame() -> ReferenceFrame:
    """A frame whose outline passes exactly through pixel centres (x = 5 and y = 5)."""
    corners = np.array([[0, 0], [4, 0], [4, 4], [0, 4]], dtype=np.float64)
    return ReferenceFrame.from_mean_shape(corners, np.array([[0, 1, 2], [0, 2, 3]], np.int32))


def test_outline_pixels_on_triangle_edges_are_filled(gl_ctx: moderngl.Context) -> None:
    frame = _square_frame()
    with pytest.raises(RuntimeError, match="unpainted"):
        GLWarp(frame, 4, gl_ctx, edge_growth=0.0)
    warp = GLWarp(frame, 4, gl_ctx)
    try:
        assert warp.n_grown > 0
        ys, xs = np.mgrid[0:40, 0:60]
        image = ((xs * 3 + ys * 2) % 256).astype(np.uint8)  # smooth ramp
        shape = np.array([[5.3, 4.1], [41.2, 6.2], [44.0, 33.5], [7.0, 30.0]])
        gpu = warp.warp_image(image, shape)
        cpu = PiecewiseAffineWarp(frame, 4).warp(image, shape)
        assert np.abs(gpu - cpu).max() <= 1.0
    finally:
        warp.release()


def _distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from point ``p`` to the line through ``a`` and ``b`` (2D)."""
    e, r = b - a, p - a
    return abs(e[0] * r[1] - e[1] * r[0]) / float(np.hypot(*e))


def test_grown_triangles_move_every_edge_out_by_the_growth() -> None:
    frame = _square_frame()
    exact, exact_pos = grown_triangle_weights(frame.vertices, frame.triangles, 4, 0.0)
    np.testing.assert_array_equal(exact.sum(axis=1), 1.0)
    np.testing.assert_array_equal(exact_pos, frame.vertices[frame.triangles.ravel()])
    grown, grown_pos = grown_triangle_weights(frame.vertices, frame.triangles, 4, 0.25)
    np.testing.assert_allclose(grown.sum(axis=1), 1.0)
    for t in range(len(frame.triangles)):
        old, new = exact_pos[3 * t : 3 * t + 3], grown_pos[3 * t : 3 * t + 3]
        centroid = old.mean(axis=0)
        for k in range(3):
            a, b = old[k], old[(k + 1) % 3]
            na, nb = new[k], new[(k + 1) % 3]
            assert _distance(centroid, na, nb) - _distance(centroid, a, b) >= 0.25 - 1e-9
