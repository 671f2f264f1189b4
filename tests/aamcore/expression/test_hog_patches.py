"""aamcore.expression.hog_patches: HOG at the landmarks and the mirror symmetry."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.expression.crop import MIRROR, aligned_face
from aamcore.expression.hog_patches import hog_block, hog_pair, mirror_symmetry
from aamcore.expression.spec import FeatureConfig
from tests.aamcore.expression.synthetic_faces import observation


def _crop(image: np.ndarray, points: np.ndarray, config: FeatureConfig
          ) -> tuple[np.ndarray, np.ndarray]:
    crop, crop_points = aligned_face(image, points, config.crop_size, config.eye_distance,
                                     config.eye_row)
    return cv2.equalizeHist(crop), crop_points


def test_hog_patches_are_normalised_and_survive_the_crop_border() -> None:
    crop = np.random.default_rng(1).integers(0, 255, (128, 128)).astype(np.uint8)
    points = np.full((68, 2), 64.0)
    points[17] = (-30.0, -30.0)  # a patch entirely outside the crop: all zeros
    config = FeatureConfig(hog_points=(17, 30))
    v = hog_block(crop, points, config).reshape(2, -1)
    assert np.all(v[0] == 0.0)
    assert np.linalg.norm(v[1]) == pytest.approx(1.0, rel=1e-4) and v[1].min() >= 0.0


def _loop_hog(crop: np.ndarray, points: np.ndarray, config: FeatureConfig) -> np.ndarray:
    """HOG patches by explicit loops: the definition :func:`hog_block` must match."""
    g = crop.astype(np.float32)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=1)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=1)
    mag, ang = np.hypot(gx, gy), np.mod(np.arctan2(gy, gx), np.pi)
    idx = np.minimum((ang * (config.hog_bins / np.pi)).astype(int), config.hog_bins - 1)
    step = 2 * config.hog_half // config.hog_cells
    out = []
    for i in config.hog_points:
        x0 = int(round(points[i, 0])) - config.hog_half
        y0 = int(round(points[i, 1])) - config.hog_half
        hists = []
        for cy in range(config.hog_cells):
            for cx in range(config.hog_cells):
                ys = slice(np.clip(y0 + cy * step, 0, 128), np.clip(y0 + (cy + 1) * step, 0, 128))
                xs = slice(np.clip(x0 + cx * step, 0, 128), np.clip(x0 + (cx + 1) * step, 0, 128))
                hists.append(np.bincount(idx[ys, xs].ravel(), mag[ys, xs].ravel(),
                                         minlength=config.hog_bins))
        v = np.concatenate(hists)
        v = np.minimum(v / (np.linalg.norm(v) + 1e-6), 0.2)
        out.append(v / (np.linalg.norm(v) + 1e-6))
    return np.concatenate(out)


def test_the_integral_histogram_hog_matches_the_loop_definition() -> None:
    rng = np.random.default_rng(4)
    crop = rng.integers(0, 255, (128, 128)).astype(np.uint8)
    points = rng.uniform(-10, 138, (68, 2))
    for config in (FeatureConfig(), FeatureConfig(hog_half=9, hog_cells=3, hog_bins=6)):
        np.testing.assert_allclose(hog_block(crop, points, config),
                                   _loop_hog(crop, points, config), atol=1e-6)


def test_a_face_unlike_its_mirror_image_has_a_low_symmetry() -> None:
    obs = observation()
    config = FeatureConfig()
    crop, points = _crop(obs.image, obs.landmarks, config)
    assert mirror_symmetry(crop, points, config) > 0.9
    half = obs.image.copy()
    half[:, 160:] = np.random.default_rng(3).integers(0, 255, half[:, 160:].shape)
    crop, points = _crop(half, obs.landmarks, config)
    assert mirror_symmetry(crop, points, config) < 0.72


def test_the_mirror_images_hog_is_read_from_the_crops_own_histograms() -> None:
    rng = np.random.default_rng(5)
    crop = cv2.GaussianBlur(rng.integers(0, 255, (128, 128)).astype(np.uint8), (0, 0), 1.0)
    crop[40:60, 30:90] = 200  # flat patches: horizontal and vertical gradients at its edges
    points = rng.uniform(-10, 138, (68, 2))
    flipped = points.copy()
    flipped[:, 0] = 127 - flipped[:, 0]
    for config in (FeatureConfig(), FeatureConfig(hog_half=9, hog_cells=3, hog_bins=6)):
        own, mirrored = hog_pair(crop, points, config)
        np.testing.assert_allclose(own, hog_block(crop, points, config), atol=1e-12)
        np.testing.assert_allclose(
            mirrored, hog_block(np.ascontiguousarray(crop[:, ::-1]), flipped[MIRROR], config),
            atol=1e-6)


def test_a_uint8_crop_gives_the_histograms_of_its_gradients_worked_out() -> None:
    """The gradients of a uint8 crop are looked up by value: the same features, to the bit,
    as a float crop of the same levels, whose gradients are binned per pixel."""
    rng = np.random.default_rng(6)
    crop = cv2.GaussianBlur(rng.integers(0, 256, (128, 128)).astype(np.uint8), (0, 0), 1.0)
    crop[50:80, 20:60] = 255  # saturated: horizontal and vertical edges
    points = rng.uniform(-20, 148, (68, 2))
    for config in (FeatureConfig(), FeatureConfig(hog_half=9, hog_cells=3, hog_bins=6)):
        as_float = crop.astype(np.float32)
        for own, other in zip(hog_pair(crop, points, config), hog_pair(as_float, points, config),
                              strict=True):
            np.testing.assert_array_equal(own, other)
        np.testing.assert_array_equal(hog_block(crop, points, config),
                                      hog_block(as_float, points, config))
