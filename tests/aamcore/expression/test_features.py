"""Pixel PCA baseline features: face crops of real JAFFE images and the per-fold PCA."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.expression.benchmark import PixelData
from aamcore.expression.features import (
    PixelPCAFeatures,
    crop_faces,
    detect_face,
    face_crop,
    face_detector,
)
from aamcore.io.jaffe import JaffeSet, parse_jaffe_name


def test_every_jaffe_face_is_found_and_cropped(jaffe_set: JaffeSet) -> None:
    samples = jaffe_set.samples[::20]
    crops = crop_faces(samples, size=32)
    assert crops.errors == []
    assert crops.pixels.shape == (len(samples), 32 * 32)
    np.testing.assert_array_equal(crops.kept, np.arange(len(samples)))
    assert crops.pixels.min() >= 0.0 and crops.pixels.max() <= 1.0
    # Histogram equalisation spreads every crop over nearly the whole grey range.
    assert np.all(crops.pixels.max(axis=1) - crops.pixels.min(axis=1) > 0.9)


def test_face_box_is_central_and_face_sized(jaffe_set: JaffeSet) -> None:
    grey = jaffe_set.samples[0].load_image()
    x, y, w, h = detect_face(grey, face_detector())
    assert 100 <= w <= 220 and 100 <= h <= 220
    assert abs(x + w / 2 - 128) < 40 and abs(y + h / 2 - 128) < 50


def test_image_without_face_is_listed_not_fatal(jaffe_set: JaffeSet, tmp_path: Path) -> None:
    blank = tmp_path / "KA.NE1.1.tiff"
    cv2.imwrite(str(blank), np.full((256, 256), 128, np.uint8))
    crops = crop_faces([jaffe_set.samples[0], parse_jaffe_name(blank)])
    np.testing.assert_array_equal(crops.kept, [0])
    assert len(crops.errors) == 1 and "KA.NE1.1.tiff" in crops.errors[0]
    assert "no face" in crops.errors[0]


def test_face_crop_keeps_the_centre_of_the_box() -> None:
    grey = np.zeros((100, 100), np.uint8)
    grey[40:60, 40:60] = 200  # bright centre, dark border
    crop = face_crop(grey, (20, 20, 60, 60), size=10, keep=0.3)
    assert crop.min() == crop.max()  # only the bright square is kept
    with pytest.raises(ValueError, match="keep"):
        face_crop(grey, (20, 20, 60, 60), keep=0.0)


def test_pca_keeps_the_variance_fraction_of_the_training_data(jaffe_pixels: PixelData) -> None:
    train = jaffe_pixels.pixels[jaffe_pixels.posers != "KA"]
    low = PixelPCAFeatures(0.9).fit(train)(jaffe_pixels.pixels)
    high = PixelPCAFeatures(0.99).fit(train)(jaffe_pixels.pixels)
    assert low.shape[0] == high.shape[0] == len(jaffe_pixels.pixels)
    assert 1 < low.shape[1] < high.shape[1] < len(train)
    assert PixelPCAFeatures(0.99).name == "pixel PCA baseline 99%"
    with pytest.raises(ValueError, match="fraction"):
        PixelPCAFeatures(95.0)
