"""Landmarks against the ground truth of real faces the test model never trained on.

The test model (the recipe on :data:`tests.conftest.MODEL_LIMIT` training faces) fits each
face of the held-out slice (:mod:`tests.aamcore.accuracy.held_out`) as the stack fits a
face it has just found: from its Haar box (from the landmark box where Haar misses it). The
trivial baseline is what the fit starts from: the mean shape placed in the same box. A
model of the recipe must land far closer to the truth than where it started, on every set,
and stay within the recorded figure's tolerance (:mod:`tests.aamcore.accuracy.figures`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from aamcore.detection.boxes import landmark_box
from aamcore.detection.haar import HaarFaceDetector
from aamcore.evaluation.fits import haar_box
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.io import FaceSample
from aamcore.io.splits import set_name_of
from tests.aamcore.accuracy.figures import HELD_OUT_NME
from tests.aamcore.accuracy.held_out import FOLDERS
from tests.aamcore.truth import nme as nme_of

pytestmark = pytest.mark.accuracy

BASELINE_RATIO = 0.6
"""The most the model's mean NME may be of the baseline's."""


@dataclass(frozen=True)
class Scored:
    """Per face (M,): the fit's NME, the baseline's, whether Haar found the face, the set."""

    fitted: np.ndarray
    baseline: np.ndarray
    detected: np.ndarray
    sets: np.ndarray


def score(small_model: FittingModel, held_out_slice: list[FaceSample]) -> Scored:
    """Each face fitted from its Haar box, and the box's mean shape, against the truth."""
    fitter, detector = Fitter(small_model), HaarFaceDetector()
    fitted, baseline, detected, sets = [], [], [], []
    for face in held_out_slice:
        image = face.load_image()
        box = haar_box(detector, image, face.points)
        start = (small_model.mapping.place(box, "detector") if box is not None
                 else small_model.mapping.place(landmark_box(face.points), "landmarks"))
        fitted.append(nme_of(fitter.fit_shape(image, start).points, face.points))
        baseline.append(nme_of(start, face.points))
        detected.append(box is not None)
        sets.append(set_name_of(face.image_path.parent))
    return Scored(*(np.array(v) for v in (fitted, baseline, detected, sets)))


@pytest.fixture(scope="module")
def scored(small_model: FittingModel, held_out_slice: list[FaceSample]) -> Scored:
    return score(small_model, held_out_slice)


def test_the_fits_land_far_closer_to_the_truth_than_the_mean_shape_in_the_box(
        scored: Scored) -> None:
    assert scored.detected.mean() >= 0.8  # Haar's boxes, mostly: the stack's start
    for name in FOLDERS:
        mine = scored.sets == name
        ratio = scored.fitted[mine].mean() / scored.baseline[mine].mean()
        assert ratio <= BASELINE_RATIO, (name, ratio)
    # most faces, not a few good ones, are fitted closer than they started
    assert np.mean(scored.fitted < 0.8 * scored.baseline) >= 0.8


def test_the_held_out_error_is_the_recorded_one(scored: Scored) -> None:
    HELD_OUT_NME.check(float(scored.fitted.mean()))
