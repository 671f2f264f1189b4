"""Landmark schemes: the iBUG-68 left-right permutation used for mirroring."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aamcore.config import resolve_dataset
from aamcore.io import load_annotated_folder
from aamcore.io.landmarks import IBUG68, IBUG68_MIRROR, mirror_points
from aamcore.model.procrustes import generalised_procrustes
from aamcore.model.similarity import Similarity

MIDLINE = {8, 27, 28, 29, 30, 33, 51, 57, 62, 66}


def test_permutation_is_an_involution_fixing_the_midline() -> None:
    perm = IBUG68_MIRROR
    assert sorted(perm.tolist()) == list(range(68))
    assert np.array_equal(perm[perm], np.arange(68))
    assert {int(k) for k in np.flatnonzero(perm == np.arange(68))} == MIDLINE


def test_partners_stay_in_their_part_and_eye_corners_swap() -> None:
    for group in ("jaw", "brows", "nose", "eyes", "mouth", "inner_mouth"):
        members = set(IBUG68.groups[group])
        assert {int(IBUG68_MIRROR[k]) for k in members} == members
    right, left = IBUG68.eye_corners
    assert IBUG68_MIRROR[right] == left
    assert set(IBUG68_MIRROR[list(IBUG68.groups["right_eye"])]) == set(IBUG68.groups["left_eye"])


def test_mirroring_a_symmetric_shape_gives_it_back() -> None:
    # Each pair at (50 -+ x, y), the midline at x = 50, in an image 101 px wide.
    rng = np.random.default_rng(1)
    shape = np.zeros((68, 2))
    for k in range(68):
        j = int(IBUG68_MIRROR[k])
        if k < j:
            x, y = rng.uniform(5, 40), rng.uniform(0, 100)
            shape[k], shape[j] = (50 - x, y), (50 + x, y)
        elif k == j:
            shape[k] = (50, rng.uniform(0, 100))
    assert np.allclose(mirror_points(shape, 101, IBUG68_MIRROR), shape)
    with pytest.raises(ValueError, match="68-point permutation"):
        mirror_points(shape[:10], 101, IBUG68_MIRROR)


def test_flipped_image_pixels_follow_the_points() -> None:
    rng = np.random.default_rng(2)
    image = rng.integers(0, 255, (40, 30), dtype=np.uint8)
    points = np.column_stack([rng.integers(0, 30, 68), rng.integers(0, 40, 68)]).astype(float)
    flipped = cv2.flip(image, 1)
    moved = mirror_points(points, image.shape[1], IBUG68_MIRROR)
    for k in range(68):
        x, y = points[IBUG68_MIRROR[k]].astype(int)
        u, v = moved[k].astype(int)
        assert flipped[v, u] == image[y, x]


def _mean_shape_error(permutation: np.ndarray) -> float:
    """Largest point distance, over the eye-corner distance, between the mean
    face of 120 LFPW faces and the mean face of their mirror images."""
    samples = load_annotated_folder(resolve_dataset("lfpw"), limit=120).samples
    shapes = np.stack([s.points for s in samples])
    widths = [cv2.imread(str(s.image_path)).shape[1] for s in samples]
    mirrored = np.stack([mirror_points(p, w, permutation)
                         for p, w in zip(shapes, widths, strict=True)])
    _, mean, _ = generalised_procrustes(shapes)
    _, mean_m, _ = generalised_procrustes(mirrored)
    aligned = Similarity.from_estimate(mean_m, mean).apply(mean_m)
    return float(np.max(np.linalg.norm(mean - aligned, axis=1))
                 / np.linalg.norm(mean[36] - mean[45]))


def test_mirrored_real_faces_keep_the_mean_face(data_dir) -> None:
    # Faces are symmetric on average: with the right pairing the mirrored faces
    # have the same mean (2.5 % of the eye-corner distance); a wrong pairing of
    # two eye points moves it by 12-22 %.
    assert _mean_shape_error(IBUG68_MIRROR) < 0.05
    wrong = IBUG68_MIRROR.copy()
    wrong[[37, 43, 38, 44]] = [43, 37, 44, 38]
    assert _mean_shape_error(wrong) > 0.08


def test_helen_is_a_dataset_name(data_dir) -> None:
    assert resolve_dataset("helen").parts[-2:] == ("helen", "trainset")
