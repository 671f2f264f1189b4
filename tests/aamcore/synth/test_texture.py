"""The face texture warped from an annotated photo into UV space."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.config import data_root
from aamcore.synth.head import synth_head
from aamcore.synth.texture import (
    face_texture,
    frontal_lfpw_photo,
    uv_to_pixels,
    warp_piecewise_affine,
)


def test_warp_maps_triangles_affinely() -> None:
    y, x = np.mgrid[0:100, 0:100].astype(float)
    image = np.dstack([2 * x, 2 * y, x + y]).astype(np.uint8)  # a smooth ramp
    src = np.array([[10, 10], [90, 10], [90, 90], [10, 90]], float)
    dst = src * 2.0  # output pixel (u, v) shows input pixel (u / 2, v / 2)
    out = warp_piecewise_affine(image, src, dst, np.array([[0, 1, 2], [0, 2, 3]]), (200, 200),
                                np.array([1, 2, 3]))
    v, u = np.mgrid[30:170, 30:170].astype(float)
    expected = np.dstack([u, v, (u + v) / 2])
    assert np.max(np.abs(out[30:170, 30:170] - expected)) <= 1.5
    assert out[5, 5].tolist() == [1, 2, 3]  # no triangle there: the fill colour


def test_uv_convention() -> None:
    assert np.allclose(uv_to_pixels(np.array([[0.0, 1.0], [1.0, 0.0]]), 100),
                       [[-0.5, -0.5], [99.5, 99.5]])


def test_texture_carries_the_photo_to_the_landmark_uvs() -> None:
    head = synth_head()
    photo, landmarks, name = frontal_lfpw_photo(data_root() / "lfpw" / "trainset")
    texture = face_texture(head, photo, landmarks, name)
    assert texture.image.shape == (1024, 1024, 3) and texture.source == name
    # The colour around each landmark in the texture is the photo's colour there.
    blur_photo = cv2.GaussianBlur(photo, (0, 0), 2.0).astype(float)
    blur_tex = cv2.GaussianBlur(texture.image, (0, 0), 4.0).astype(float)
    px = np.round(landmarks).astype(int)
    at_photo = blur_photo[px[:, 1], px[:, 0]]
    uv_px = np.round(uv_to_pixels(head.landmark_uvs, 1024)).astype(int)
    at_tex = blur_tex[uv_px[:, 1], uv_px[:, 0]]
    assert np.corrcoef(at_photo.ravel(), at_tex.ravel())[0, 1] > 0.9
    shuffled = at_tex[np.random.default_rng(1).permutation(68)]
    assert np.corrcoef(at_photo.ravel(), shuffled.ravel())[0, 1] < 0.8
    with pytest.raises(ValueError, match="68 finite"):
        face_texture(head, photo, landmarks[:10])
