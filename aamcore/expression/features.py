"""The pixel PCA baseline features: face crops and a PCA fitted inside each fold.

Until the fitted AAM appearance vector ``c`` is available, expressions are
classified from the grey levels of the detected face: Haar detection
(``haarcascade_frontalface_alt2``, trained elsewhere and not on these data),
crop of the inner 80 % of the box, resize to 48x48, histogram equalisation.
These steps look at one image at a time, so computing them once for all
images leaks nothing between folds.
The only learned step, the PCA that keeps a fraction of the variance (like
the AAM variances of table 9.2), is fitted on the training fold by
:class:`PixelPCAFeatures`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
from sklearn.decomposition import PCA

from aamcore.detection.haar import HaarFaceDetector
from aamcore.io.jaffe import ExpressionSample
from aamcore.io.sample import DatasetError

CASCADE_NAME = "haarcascade_frontalface_alt2.xml"
BASELINE_NAME = "pixel PCA baseline"


def face_detector() -> HaarFaceDetector:
    """The detector of the baseline: ``alt2`` at scale step 1.1, faces from 48 px."""
    return HaarFaceDetector(CASCADE_NAME, scale_factor=1.1, min_size=(48, 48))


def detect_face(grey: np.ndarray, detector: HaarFaceDetector) -> tuple[int, int, int, int]:
    """Largest face box ``(x, y, w, h)`` in a grey image (H, W).

    Raises
    ------
    ValueError
        If no face is found.
    """
    boxes = detector.detect(grey)
    if len(boxes) == 0:
        raise ValueError("no face found by the Haar detector")
    x, y, w, h = (int(round(v)) for v in boxes[0])
    return x, y, w, h


def face_crop(
    grey: np.ndarray, box: tuple[int, int, int, int], size: int = 48, keep: float = 0.8
) -> np.ndarray:
    """Crop the centre of ``box``, resize to (size, size) and equalise its histogram.

    Parameters
    ----------
    grey : (H, W) uint8 array
    box : (x, y, w, h)
        Face box from :func:`detect_face`.
    size : int
        Side of the square crop returned.
    keep : float
        Fraction of the box side kept around its centre: the borders of a
        Haar box hold hair and background rather than expression.
    """
    if not 0.0 < keep <= 1.0:
        raise ValueError(f"keep must be in (0, 1], got {keep}")
    x, y, w, h = box
    dx, dy = round(w * (1.0 - keep) / 2), round(h * (1.0 - keep) / 2)
    patch = grey[y + dy : y + h - dy, x + dx : x + w - dx]
    patch = cv2.resize(patch, (size, size), interpolation=cv2.INTER_AREA)
    return cv2.equalizeHist(patch)


@dataclass
class FaceCrops:
    """Flattened face crops of the samples in which a face was found.

    Attributes
    ----------
    pixels : (n, size * size) float64 array
        Grey levels in [0, 1].
    kept : (n,) int array
        Index of each row in the sample list given.
    errors : list of str
        One message per sample left out, naming its file.
    """

    pixels: np.ndarray
    kept: np.ndarray
    errors: list[str] = field(default_factory=list)


def crop_faces(samples: Sequence[ExpressionSample], size: int = 48, keep: float = 0.8) -> FaceCrops:
    """Detect, crop and equalise the face of every sample; samples without a face are listed."""
    detector = face_detector()
    rows: list[np.ndarray] = []
    kept: list[int] = []
    errors: list[str] = []
    for i, sample in enumerate(samples):
        try:
            grey = sample.load_image()
            crop = face_crop(grey, detect_face(grey, detector), size, keep)
        except (ValueError, DatasetError) as exc:
            errors.append(f"{sample.image_path}: {exc}")
            continue
        rows.append(crop.reshape(-1).astype(np.float64) / 255.0)
        kept.append(i)
    pixels = np.array(rows) if rows else np.empty((0, size * size))
    return FaceCrops(pixels, np.array(kept, dtype=np.int64), errors)


class PixelPCAFeatures:
    """Per-fold PCA of face-crop pixels keeping a fraction of the variance.

    Parameters
    ----------
    variance : float
        Fraction of the training variance kept, in (0, 1), e.g. 0.95.
    """

    def __init__(self, variance: float) -> None:
        if not 0.0 < variance < 1.0:
            raise ValueError(f"variance must be a fraction in (0, 1), got {variance}")
        self.variance = variance
        self.name = f"{BASELINE_NAME} {100 * variance:g}%"

    def fit(self, train_inputs: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """Fit the PCA on training pixels (n, p); return the map pixels (m, p) -> (m, t)."""
        pca = PCA(n_components=self.variance, svd_solver="full").fit(np.asarray(train_inputs))
        return pca.transform
