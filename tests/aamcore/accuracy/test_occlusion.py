"""Occlusion flags against the truth, on real faces the test model never saw.

Each face of the held-out slice is shown as it is and with one occluder drawn over it by
the generator the occlusion test learns from (:mod:`aamcore.fitting.occluders`: a hand in
a skin tone, an object, a lock of hair, sunglasses, in turn), and fitted as the stack fits
it (the recipe's fitter, from the mean shape placed on the face's landmark box). On the
good fits a landmark is *covered* when the occluder hides at least half its part of the
face and *visible* when it hides none of it (the generator's truth,
:func:`~aamcore.fitting.occluders.covered_shares`); the test model must flag most covered
landmarks and few visible ones, and stay within the recorded figures' tolerance
(:mod:`tests.aamcore.accuracy.figures`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from aamcore.detection.boxes import landmark_box
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.occluders import DRAWN, covered_shares, draw_occluder
from aamcore.io import FaceSample
from tests.aamcore.accuracy.figures import OCCLUDED_FLAGGED, VISIBLE_FLAGGED

pytestmark = pytest.mark.accuracy

COVERED, VISIBLE = 0.5, 0.0
"""A landmark is covered at or above this share of its part of the face, visible at none."""


@dataclass
class Flags:
    """Counts over the good fits of the held-out slice."""

    covered: int = 0
    covered_flagged: int = 0
    visible: int = 0
    visible_flagged: int = 0
    clean: int = 0
    clean_flagged: int = 0
    fits: int = 0
    good: int = 0

    def rate(self, part: str) -> float:
        return getattr(self, f"{part}_flagged") / max(getattr(self, part), 1)


def count_flags(small_model: FittingModel, held_out_slice: list[FaceSample]) -> Flags:
    """The flags of the good fits of each face, clean and with an occluder, counted."""
    fitter = Fitter(small_model)
    assert fitter.occlusion is not None  # the recipe's fitter flags occluded landmarks
    out = Flags()
    other = held_out_slice[-1].load_image()
    for k, face in enumerate(held_out_slice):
        image, truth = face.load_image(), face.points
        start = small_model.mapping.place(landmark_box(truth), "landmarks")
        drawn, mask = draw_occluder(image, truth, np.random.default_rng(k), DRAWN[k % 4], other)
        for shown, hidden in ((image, None), (drawn, mask)):
            fit = fitter.fit_shape(shown, start)
            out.fits += 1
            if not fit.ok:
                continue
            out.good += 1
            flagged = fit.occluded
            if hidden is None:
                out.clean += len(flagged)
                out.clean_flagged += int(flagged.sum())
                continue
            shares = covered_shares(hidden, truth)
            covered, visible = shares >= COVERED, shares <= VISIBLE
            out.covered += int(covered.sum())
            out.covered_flagged += int((flagged & covered).sum())
            out.visible += int(visible.sum())
            out.visible_flagged += int((flagged & visible).sum())
        other = image
    return out


@pytest.fixture(scope="module")
def flags(small_model: FittingModel, held_out_slice: list[FaceSample]) -> Flags:
    return count_flags(small_model, held_out_slice)


def test_covered_landmarks_are_flagged_and_visible_ones_are_not(flags: Flags) -> None:
    assert flags.good >= 0.8 * flags.fits, (flags.good, flags.fits)
    assert flags.covered >= 200 and flags.visible >= 1000  # enough of each to judge
    assert flags.rate("covered") >= 0.5, flags
    assert flags.rate("visible") <= 0.15 and flags.rate("clean") <= 0.15, flags
    assert flags.rate("covered") >= 4 * max(flags.rate("visible"), flags.rate("clean")), flags


def test_the_flags_are_the_recorded_ones(flags: Flags) -> None:
    OCCLUDED_FLAGGED.check(flags.rate("covered"))
    VISIBLE_FLAGGED.check(flags.rate("visible"))
