"""AAM appearance features for expression recognition (thesis chapter 9).

JAFFE has no landmarks, so the faces are described in two steps:

1. A generic fitter, trained on LFPW only (it never sees JAFFE), finds the 68
   landmarks of every face from its Haar box. Faces where Haar finds nothing
   or the fit fails the test of eq. 7.2 are reported and left out.
2. Inside each fold, an AAM is built from the training posers' faces and
   fitted landmarks only, and every face (training or test) is described by
   its appearance vector ``c`` in that AAM. The test poser never enters the
   model that describes it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.fitter import Fitter
from aamcore.io import DatasetError, FaceSample
from aamcore.io.jaffe import ExpressionSample
from aamcore.io.landmarks import LandmarkScheme
from aamcore.model.training import TrainConfig, train_aam


@dataclass
class FittedFaces:
    """Expression samples with fitted landmarks.

    Attributes
    ----------
    samples : list of FaceSample
        The kept faces, with the fitted landmarks as ``points`` and the poser
        as ``subject``.
    kept : (n,) int array
        Index of each kept face in the sample list given.
    scheme : LandmarkScheme
    appearance : (n, t_c) array
        The fitter's own appearance parameters ``c`` of each kept face.
    errors : list of str
        One message per face left out, naming its file and why.
    """

    samples: list[FaceSample]
    kept: np.ndarray
    scheme: LandmarkScheme
    appearance: np.ndarray
    errors: list[str] = field(default_factory=list)


def fit_faces(
    samples: Sequence[ExpressionSample], fitter: Fitter, detector: HaarFaceDetector | None = None
) -> FittedFaces:
    """Fit every sample's face from its Haar box; leave out (and list) faces without a good fit.

    Raises
    ------
    ValueError
        When ``fitter`` gives no appearance ``c`` (a method that computes none,
        without ``appearance=True``).
    """
    detector = detector or HaarFaceDetector(min_size=(48, 48))
    fitted, kept, appearance, errors = [], [], [], []
    for i, sample in enumerate(samples):
        try:
            image = sample.load_image()
        except DatasetError as exc:
            errors.append(str(exc))
            continue
        boxes = detector.detect(image)
        if len(boxes) == 0:
            errors.append(f"{sample.image_path}: no face found by the Haar detector")
            continue
        result = fitter.fit_box(image, boxes[0])
        if result.failed:
            errors.append(f"{sample.image_path}: fit failed ({result.reason})")
            continue
        if result.c.size != fitter.aam.n_appearance:
            raise ValueError(f"the fitter's {fitter.name} fits carry no appearance: give "
                             "the Fitter appearance=True")
        fitted.append(FaceSample(sample.image_path, result.points, sample.poser))
        kept.append(i)
        appearance.append(result.c)
    coded = np.array(appearance).reshape(len(appearance), fitter.aam.n_appearance)
    return FittedFaces(fitted, np.array(kept, dtype=np.int64), fitter.aam.scheme, coded, errors)


class AAMAppearanceFeatures:
    """Per-fold AAM appearance vectors ``c`` of fitted faces.

    Inputs are :class:`~aamcore.io.FaceSample` objects with fitted
    landmarks (from :func:`fit_faces`).

    Parameters
    ----------
    scheme : LandmarkScheme
    variance : float
        Fraction of the variance the shape, texture and combined models keep
        (table 9.2 varies it from 95 % to 99.9 %).
    n_pixels : int
        Reference frame size.
    equalise : bool
        Histogram-equalise the face region before sampling textures (thesis
        section 4.3); on JAFFE it lifted the leave-one-poser-out rates by a
        few points.
    """

    def __init__(
        self, scheme: LandmarkScheme, variance: float, n_pixels: int = 6000, equalise: bool = False
    ) -> None:
        self.equalise = equalise
        self.scheme = scheme
        self.variance = variance
        self.n_pixels = n_pixels
        self.name = f"AAM appearance {100 * variance:g}%"

    def fit(
        self, train_inputs: Sequence[FaceSample]
    ) -> Callable[[Sequence[FaceSample]], np.ndarray]:
        """Train the fold's AAM on ``train_inputs``; return the map faces -> c (m, t_c)."""
        v = self.variance
        config = TrainConfig(
            shape_variance=v,
            texture_variance=v,
            combined_variance=v,
            n_pixels=self.n_pixels,
            colour=False,
            equalise=self.equalise,
        )
        aam = train_aam(list(train_inputs), self.scheme, config, source="expression fold")

        def transform(inputs: Sequence[FaceSample]) -> np.ndarray:
            return np.stack([aam.parameters_of(s.load_image(), s.points)[0] for s in inputs])

        return transform
