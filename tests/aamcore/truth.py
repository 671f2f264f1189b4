"""Video with exact landmarks for the tracking tests, and fits scored against them.

A held-out LFPW photo (a face no model of the recipe trained on) moves over a 640 x 360
canvas as :func:`aamcore.synth.motion.generate` moves it, slowly: every frame has its
truth, so a test asks whether each fit is *right*, not whether the fitter says it is good.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from aamcore.face_result import FaceResult
from aamcore.fitting.result import FitResult
from aamcore.io import FaceSample, load_annotated_folder
from aamcore.io.splits import split
from aamcore.synth.motion import MotionSpec, Sequence, generate

RIGHT = 0.15
"""The largest NME (mean point error over the truth's outer-eye-corner distance) of a fit
counted right: a fit on the face, however rough, against a lost one (0.3 and more). The
small test model's fits of the clips below measure 0.03 to 0.08."""
SLOW = MotionSpec(frames=40, max_angle_deg=10.0, scales=(0.9, 1.1), speed=0.5, seed=11,
                  blur=False)
"""A face moving slowly, as before a webcam (a few pixels a frame: no motion blur to speak
of, and its filter would cost more than the tracking)."""


@cache
def _held_out(lfpw_dir: Path) -> list[FaceSample]:
    return split(load_annotated_folder(lfpw_dir).samples, "lfpw")[1]


def held_out_photo(lfpw_dir: Path, index: int = 4) -> FaceSample:
    """The ``index``-th held-out LFPW face (:mod:`aamcore.io.splits`)."""
    return _held_out(lfpw_dir)[index]


def clip(lfpw_dir: Path, spec: MotionSpec = SLOW, index: int = 4) -> Sequence:
    """The held-out face ``index`` moving as ``spec`` says."""
    face = held_out_photo(lfpw_dir, index)
    return generate(face.load_image(), face.points, spec)


def nme(points: np.ndarray, truth: np.ndarray) -> float:
    """Mean point error of 68 ``points`` over the ``truth``'s outer-eye-corner distance."""
    iod = float(np.linalg.norm(truth[45] - truth[36]))
    return float(np.linalg.norm(np.asarray(points) - truth, axis=1).mean() / iod)


def right(result: FitResult | None, truth: np.ndarray, limit: float = RIGHT) -> bool:
    """Whether ``result`` is a good fit (by the fitter's own test) that is right (by the
    truth)."""
    return result is not None and result.ok and nme(result.points, truth) <= limit


def right_face(result: FaceResult, truth: np.ndarray, limit: float = RIGHT) -> bool:
    """:func:`right` for a :class:`~aamcore.FaceResult` of the one-call API."""
    return result.success and nme(result.landmarks, truth) <= limit


def wrong_but_good(result: FitResult | None, truth: np.ndarray) -> bool:
    """Whether the fitter calls ``result`` good while it is off the face."""
    return result is not None and result.ok and nme(result.points, truth) > 2 * RIGHT
