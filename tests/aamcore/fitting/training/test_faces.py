"""aamcore.fitting.training.faces: shrinking, mirroring, packed pixel sampling."""

from __future__ import annotations

import cv2
import numpy as np

from aamcore.fitting.training.faces import PackedImages, prepare_faces, scaled, shrink_face
from aamcore.io.landmarks import IBUG68_MIRROR


def test_shrink_keeps_small_faces_and_scales_large_ones() -> None:
    image = np.zeros((400, 600, 3), np.uint8)
    points = np.array([[100.0, 100.0], [500.0, 300.0]])
    grey, f = shrink_face(image, points, 200.0)
    assert grey.shape == (200, 300) and f == 0.5
    same, one = shrink_face(image[..., 0], points * 0.4, 200.0)
    assert same.shape == (400, 600) and one == 1.0
    assert np.allclose(scaled([[0.0, 0.0], [599.0, 399.0]], 0.5), [[-0.25, -0.25],
                                                                    [299.25, 199.25]])


def test_mirrored_faces_share_the_photo_and_flip_the_points() -> None:
    rng = np.random.default_rng(0)
    grey = rng.integers(0, 255, (50, 40), np.uint8)
    points = rng.uniform(5, 35, (68, 2))
    faces = prepare_faces([grey], [1.0], [points], [points + 1], [True], IBUG68_MIRROR)
    assert len(faces) == 2 and faces[0].photo == faces[1].photo == 0
    assert np.array_equal(faces[1].grey, cv2.flip(grey, 1))
    assert np.allclose(faces[1].points[45], [39 - points[36, 0], points[36, 1]])
    assert faces[1].detected and np.allclose(faces[1].start[45], [38 - points[36, 0],
                                                                   points[36, 1] + 1])
    assert len(prepare_faces([grey], [1.0], [points], [points], [False], None)) == 1


def test_packed_differences_read_the_right_pixels() -> None:
    rng = np.random.default_rng(1)
    images = [rng.integers(0, 255, (30, 40), np.uint8), rng.integers(0, 255, (20, 25), np.uint8)]
    packed = PackedImages.pack(images)
    owners = np.array([0, 1, 1])
    anchors = np.array([[10.2, 12.7], [3.0, 4.0], [24.0, 19.0]])
    ab = np.array([[1.0, 0.0], [2.0, 0.0], [1.0, 0.0]])
    offsets = np.array([[1.0, 2.0, -3.0, 0.0], [50.0, 0.0, 0.0, -50.0]])
    d = packed.differences(owners, anchors, ab, offsets)
    img = images[0]
    assert d[0, 0] == int(img[15, 11]) - int(img[13, 7])
    img = images[1]
    assert d[1, 0] == int(img[8, 5]) - int(img[4, 0])  # scaled by 2, clamped at 0
    assert d[2, 1] == int(img[19, 24]) - int(img[0, 24])  # clamped at the far borders
