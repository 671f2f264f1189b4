"""One fitted face as the expression stage sees it, and its canonical (eye-aligned) frame.

The expression stage takes, per frame, a :class:`FaceObservation`: the frame
itself, the 68 iBUG landmarks and the appearance vector ``c`` of the fit.
Everything it computes is in a canonical frame where the eye centres are
level and a fixed distance apart (:func:`canonical_transform`): the
canonical shape (:func:`canonical_shape`, eye centres at (-0.5, 0) and
(0.5, 0)) and the face crop (:func:`aligned_face`) that the HOG patches are
taken from (:mod:`.hog_patches`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

N_LANDMARKS = 68
"""The features expect the iBUG 68-point markup."""
SCHEME = "ibug68"
"""The landmark scheme's name, as the fitter's ``Fit`` messages carry it."""
LEFT_EYE = tuple(range(36, 42))
RIGHT_EYE = tuple(range(42, 48))
INNER_SLICE = slice(17, 68)
INNER_POINTS = tuple(range(INNER_SLICE.start, INNER_SLICE.stop))
"""Brows, nose, eyes and mouth: the landmarks whose neighbourhoods carry the expression
(:data:`INNER_SLICE` as a slice)."""
NOSE_TIP = 30
YAW_NOSE_GAIN = 0.57
"""Nose-tip offset from the eye midpoint, in eye distances, per unit of ``tan(yaw)``: on the
OpenFace mean 3D face turned 10 to 60 degrees it is 0.49 to 0.60 (0.565 at 30 degrees)."""
MIRROR = np.array(
    [*range(16, -1, -1), *range(26, 21, -1), *range(21, 16, -1), 27, 28, 29, 30, 35, 34, 33, 32,
     31, 45, 44, 43, 42, 47, 46, 39, 38, 37, 36, 41, 40, 54, 53, 52, 51, 50, 49, 48, 59, 58, 57,
     56, 55, 64, 63, 62, 61, 60, 67, 66, 65]
)
"""The iBUG point that each point becomes in the mirror image (0 <-> 16, 36 <-> 45, ...)."""
_TINY = 1e-6


class FaceFeatureError(ValueError):
    """The features of a face cannot be computed (wrong landmark count, degenerate eyes)."""


@dataclass(frozen=True, eq=False)
class FaceObservation:
    """What the expression stage gets for one frame.

    Attributes
    ----------
    image : (H, W) or (H, W, 3) uint8 array
        The frame, grey or BGR.
    landmarks : (N, 2) float64 array
        The fitter's landmarks in frame pixels; (0, 2) when no face was found.
    appearance : (k,) float64 array
        The fitter's appearance parameters ``c``; (0,) when no face was found.
    fit_failed : bool
        Whether the fitter's own failure test rejected the fit.
    fit_reason : str
        The fitter's reason (``"no face"`` when the detector found none).
    occluded : (N,) bool array or None
        The fit's per-landmark occlusion flags; None where they were not judged.
    """

    image: np.ndarray
    landmarks: np.ndarray
    appearance: np.ndarray
    fit_failed: bool = False
    fit_reason: str = ""
    occluded: np.ndarray | None = None

    @classmethod
    def from_arrays(
        cls,
        image: np.ndarray,
        landmarks: np.ndarray | None,
        appearance: np.ndarray | None,
        fit_failed: bool = False,
        fit_reason: str = "",
        occluded: np.ndarray | None = None,
    ) -> FaceObservation:
        """Build from arrays of any float type; ``None`` for a frame without a face.

        The landmarks and ``c`` are rounded to float32, the precision of the
        fitter's ``Fit`` message, so that the library (which has the fit's
        float64 arrays) and the expression service (which has the message's)
        compute the same features.
        """
        points = np.zeros((0, 2)) if landmarks is None else _as_published(landmarks)
        c = np.zeros(0) if appearance is None else _as_published(appearance).ravel()
        flags = None
        if occluded is not None and len(occluded) == len(points.reshape(-1, 2)):
            flags = np.asarray(occluded, bool)
        return cls(np.asarray(image), points.reshape(-1, 2), c, bool(fit_failed),
                   str(fit_reason), flags)


def _as_published(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, np.float32).astype(np.float64)


def check_landmarks(points: np.ndarray) -> None:
    """Raise :class:`FaceFeatureError` unless ``points`` is a finite (68, 2) array."""
    if points.shape != (N_LANDMARKS, 2):
        raise FaceFeatureError(
            f"expected {N_LANDMARKS} iBUG landmarks (68, 2), got an array of shape {points.shape}"
        )
    if not np.all(np.isfinite(points)):
        raise FaceFeatureError("the landmarks have non-finite coordinates")


def eye_centres(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (2,) of the left-in-image and right-in-image eye, from (68, 2) landmarks."""
    # np.mean's arithmetic (a sum, then a division) on the eyes' rows, without its overhead
    return (np.add.reduce(points[LEFT_EYE[0]:LEFT_EYE[-1] + 1], axis=0) / len(LEFT_EYE),
            np.add.reduce(points[RIGHT_EYE[0]:RIGHT_EYE[-1] + 1], axis=0) / len(RIGHT_EYE))


def canonical_transform(
    points: np.ndarray, eye_distance: float = 1.0, centre: tuple[float, float] = (0.0, 0.0)
) -> np.ndarray:
    """The similarity putting the eye centres level, ``eye_distance`` apart, around ``centre``.

    Parameters
    ----------
    points : (68, 2) array
        Landmarks in image pixels.
    eye_distance : float
        Distance between the eye centres after the transform.
    centre : (float, float)
        Where their midpoint goes.

    Returns
    -------
    (2, 3) float64 array
        Affine matrix ``M``: ``p' = M[:, :2] @ p + M[:, 2]``.

    Raises
    ------
    FaceFeatureError
        When the eye centres coincide or are not finite.
    """
    left, right = eye_centres(points)
    d = right - left
    dist = float(np.hypot(d[0], d[1]))
    if not math.isfinite(dist) or dist < _TINY:
        raise FaceFeatureError("the eye centres coincide or are not finite")
    s = eye_distance / dist
    cos, sin = d / dist
    M = np.empty((2, 3))
    A = M[:, :2]
    A[...] = s * np.array([[cos, sin], [-sin, cos]])
    M[:, 2] = np.asarray(centre, np.float64) - A @ ((left + right) / 2.0)
    return M


def transform_points(M: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a (2, 3) affine matrix to (N, 2) points; (N, 2)."""
    return points @ M[:, :2].T + M[:, 2]


def canonical_shape(points: np.ndarray) -> np.ndarray:
    """Landmarks (68, 2) with the eye centres at (-0.5, 0) and (0.5, 0); (68, 2)."""
    return transform_points(canonical_transform(points), points)


def approximate_yaw_deg(points: np.ndarray) -> float:
    """Head turn in degrees from 2-D landmarks (68, 2), positive when the nose points to +x.

    The nose tip's horizontal offset from the eye midpoint, in eye distances,
    is about ``YAW_NOSE_GAIN * tan(yaw)`` (the eye distance shrinks with
    ``cos(yaw)``, the offset grows with ``sin(yaw)``); a frontal face has
    offset 0. Accurate to a few degrees on a mean face, rougher on real faces
    (the nose tip's own position differs between people).
    """
    return yaw_of_canonical(canonical_shape(points))


def yaw_of_canonical(shape: np.ndarray) -> float:
    """:func:`approximate_yaw_deg` of landmarks whose :func:`canonical_shape` (68, 2) is
    ``shape``."""
    return float(np.degrees(np.arctan2(float(shape[NOSE_TIP, 0]), YAW_NOSE_GAIN)))


def grey(image: np.ndarray) -> np.ndarray:
    """The image as (H, W) uint8 grey levels (BGR, BGRA or float input)."""
    if image.ndim == 3:
        code = cv2.COLOR_BGRA2GRAY if image.shape[2] == 4 else cv2.COLOR_BGR2GRAY
        image = cv2.cvtColor(image, code)
    if image.dtype != np.uint8:
        image = cv2.normalize(image.astype(np.float32), None, 0, 255, cv2.NORM_MINMAX)
        image = image.astype(np.uint8)
    return image


def aligned_face(
    image: np.ndarray, points: np.ndarray, size: int, eye_distance: float, eye_row: float
) -> tuple[np.ndarray, np.ndarray]:
    """The face warped to the canonical crop, and the landmarks in it.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) array
    points : (68, 2) array
        Landmarks in image pixels.
    size : int
        Side of the square crop, pixels.
    eye_distance, eye_row : float
        Distance between the eye centres and their row in the crop, pixels.

    Returns
    -------
    crop : (size, size) uint8 array
        Pixels beyond the frame repeat its border.
    crop_points : (68, 2) float64 array
    """
    M = canonical_transform(points, eye_distance, (size / 2.0, eye_row))
    crop = cv2.warpAffine(
        _grey_under(image, M, size), M, (size, size), flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    return crop, transform_points(M, points)


def _grey_under(image: np.ndarray, M: np.ndarray, size: int) -> np.ndarray:
    """The grey levels (H, W) uint8 of ``image`` that the warp by ``M`` to a ``size`` crop
    reads: a BGR(A) uint8 frame is converted only in the box the crop comes from (with a
    margin), the rest of the array left unset, which the warp never reads (pixels beyond
    the frame repeat its border, which the box then holds); any other image as
    :func:`grey` gives it."""
    if image.ndim != 3 or image.dtype != np.uint8 or image.shape[2] not in (3, 4):
        return grey(image)
    h, w = image.shape[:2]
    inverse = cv2.invertAffineTransform(M)
    xs, ys = (inverse[:, :2] @ _CORNERS * size + inverse[:, 2:]).tolist()
    x0, x1 = _span(min(xs), max(xs), w)
    y0, y1 = _span(min(ys), max(ys), h)
    if (x1 - x0) * (y1 - y0) * 2 > h * w:
        return grey(image)
    out = np.empty((h, w), np.uint8)
    code = cv2.COLOR_BGRA2GRAY if image.shape[2] == 4 else cv2.COLOR_BGR2GRAY
    cv2.cvtColor(image[y0:y1, x0:x1], code, dst=out[y0:y1, x0:x1])
    return out


_CORNERS = np.array([[0.0, 0.0, 1.0, 1.0], [0.0, 1.0, 0.0, 1.0]])
"""The corners of the unit square, by columns."""


def _span(low: float, high: float, n: int) -> tuple[int, int]:
    """The pixels ``start:stop`` of ``0:n`` that a bilinear read between ``low`` and
    ``high`` touches, pixels beyond ``0:n`` replicating its ends (two pixels to spare)."""
    return (min(max(math.floor(low) - 2, 0), n - 1),
            min(max(math.ceil(high) + 2, 0), n - 1) + 1)
