"""The quality gate: whether a fitted face can be classified at all, and why not.

A face is refused, with a reason of the form ``"<short key>: <details>"``
(:func:`reason_key` gives the key), when no face was found, its landmarks are
unusable, it is too small, mostly outside the frame, rolled or turned into
profile, its canonical shape is unlike the training faces', or, from its crop, it is
blurred (:func:`blur_problem`) or its texture does not match its mirror image
(:func:`symmetry_problem`). The
fitter's own failure flag is not a reason: on expressive faces its appearance
test often fails while the landmarks are right.
"""

from __future__ import annotations

import cv2
import numpy as np

from aamcore.expression.crop import (
    INNER_SLICE,
    FaceFeatureError,
    FaceObservation,
    canonical_shape,
    check_landmarks,
    eye_centres,
    yaw_of_canonical,
)
from aamcore.expression.spec import QualityLimits

NO_FACE = "no face"
BLURRED = "face blurred"
LEARNING = "learning the face's reference"
"""The reason of a classifiable face while the stream's reference is too young."""


def reason_key(reason: str) -> str:
    """The short key of a reason (what precedes its first colon): ``"face in profile"``."""
    return reason.split(":", 1)[0].strip()


def shape_deviation(points: np.ndarray, template: np.ndarray) -> float:
    """RMS distance (eye distances) of the canonical shape of (68, 2) ``points`` from a
    (68, 2) canonical ``template``."""
    return deviation_of_canonical(canonical_shape(points), template)


def deviation_of_canonical(shape: np.ndarray, template: np.ndarray) -> float:
    """:func:`shape_deviation` of landmarks whose canonical shape (68, 2) is ``shape``."""
    # np.sum and np.mean's arithmetic, without their wrappers
    squared = np.add.reduce((shape - template) ** 2, axis=1)
    return float(np.sqrt(np.add.reduce(squared) / len(squared)))


def _no_face(observation: FaceObservation) -> str:
    why = observation.fit_reason
    return NO_FACE if not why else why if why.startswith(NO_FACE) else f"{NO_FACE}: {why}"


def _placement_problem(points: np.ndarray, image_shape: tuple[int, ...],
                       limits: QualityLimits) -> str:
    """Too small, outside the frame or rolled: ``""`` when none."""
    left, right = eye_centres(points)
    d = right - left
    eye_distance = float(np.hypot(d[0], d[1]))
    if eye_distance < limits.min_eye_distance:
        return (f"face too small: eye centres {eye_distance:.1f} px apart "
                f"(at least {limits.min_eye_distance:g} px needed)")
    h, w = image_shape[:2]
    inside = (points[:, 0] >= 0) & (points[:, 0] < w) & (points[:, 1] >= 0) & (points[:, 1] < h)
    outside = 1.0 - float(inside.mean())
    if outside > limits.max_outside:
        return f"face outside the frame: {100 * outside:.0f} % of the landmarks beyond it"
    roll = float(np.degrees(np.arctan2(d[1], d[0])))
    if abs(roll) > limits.max_roll_deg:
        return f"head rolled: {roll:.0f} degrees (at most {limits.max_roll_deg:g})"
    return ""


def landmark_problem(
    observation: FaceObservation,
    limits: QualityLimits = QualityLimits(),
    template: np.ndarray | None = None,
) -> str:
    """Why a face cannot be classified, judged from its landmarks alone, or ``""``.

    The checks, in order: found; 68 finite landmarks; eyes at least
    ``limits.min_eye_distance`` px apart; at most ``limits.max_outside`` of
    the landmarks outside the frame; eye line within ``limits.max_roll_deg``;
    at most ``limits.max_covered`` of the inner landmarks flagged occluded (when
    the fit has flags); head turned at most ``limits.max_yaw_deg``; and, when ``template`` is
    given, a canonical shape within ``limits.max_shape_deviation`` eye
    distances RMS of it.

    Parameters
    ----------
    observation : FaceObservation
    limits : QualityLimits
    template : (68, 2) array, optional
        Mean canonical shape (:func:`~aamcore.expression.crop.canonical_shape`)
        of the training faces.

    Returns
    -------
    str
        Empty, or a reason ``"<key>: <details>"`` (``"no face"`` alone when the
        detector found none).
    """
    return landmark_gate(observation, limits, template)[0]


def landmark_gate(
    observation: FaceObservation,
    limits: QualityLimits = QualityLimits(),
    template: np.ndarray | None = None,
) -> tuple[str, np.ndarray | None]:
    """:func:`landmark_problem`, and the landmarks' canonical shape (68, 2) where the gate
    got that far (None otherwise), for the features to use again."""
    points = observation.landmarks
    if points.size == 0:
        return _no_face(observation), None
    try:
        check_landmarks(points)
    except FaceFeatureError as exc:
        return f"unusable landmarks: {exc}", None
    placed = _placement_problem(points, observation.image.shape, limits)
    if placed:
        return placed, None
    covered = covered_share(observation.occluded)
    if covered > limits.max_covered:
        return (f"face covered: {100 * covered:.0f} % of the inner landmarks occluded "
                f"(at most {100 * limits.max_covered:g} %)"), None
    shape = canonical_shape(points)
    yaw = yaw_of_canonical(shape)
    if abs(yaw) > limits.max_yaw_deg:
        return (f"face in profile: turned about {yaw:.0f} degrees (at most "
                f"{limits.max_yaw_deg:g})"), shape
    if template is not None:
        deviation = deviation_of_canonical(shape, template)
        if deviation > limits.max_shape_deviation:
            return (f"implausible landmarks: {deviation:.2f} eye distances RMS from the face "
                    f"shapes the classifier was trained on (at most "
                    f"{limits.max_shape_deviation:g})"), shape
    return "", shape


def covered_share(flags: np.ndarray | None) -> float:
    """The share of the inner landmarks (brows, eyes, nose, mouth) a fit's occlusion
    ``flags`` (68,) mark covered; 0 without flags."""
    return 0.0 if flags is None or len(flags) == 0 else float(np.mean(flags[INNER_SLICE]))


def symmetry_problem(symmetry: float, limits: QualityLimits = QualityLimits(),
                     flags: np.ndarray | None = None) -> str:
    """The reason to refuse a face of this mirror symmetry, or ``""``: a face whose
    landmarks passed as frontal and some of whose inner landmarks the fit's occlusion
    ``flags`` (68,) mark is covered (a hand on one side is what makes it unlike its mirror),
    else it is turned further than its landmarks say or badly fitted."""
    if symmetry >= limits.min_symmetry:
        return ""
    covered = covered_share(flags)
    if covered > 0:
        return (f"face covered: {100 * covered:.0f} % of the inner landmarks occluded, and "
                f"the face matches its mirror image {symmetry:.2f} (at least "
                f"{limits.min_symmetry:g} for a frontal face)")
    return (f"face in profile or badly fitted: it matches its mirror image {symmetry:.2f} "
            f"(at least {limits.min_symmetry:g} for a frontal face)")


def sharpness(equalised: np.ndarray, points: np.ndarray) -> float:
    """How sharp a face is: the variance of the Laplacian (grey levels squared) of its
    equalised canonical crop (S, S) uint8 over the box of the inner landmarks ``points``
    (68, 2), crop pixels: the texture an expression is read from, whatever the lighting."""
    inner = points[INNER_SLICE]
    (x0, y0), (x1, y1) = inner.min(axis=0).tolist(), inner.max(axis=0).tolist()
    h, w = equalised.shape[:2]
    x0, y0 = min(max(int(x0), 0), w - 3), min(max(int(y0), 0), h - 3)
    x1, y1 = max(min(int(x1) + 2, w), x0 + 3), max(min(int(y1) + 2, h), y0 + 3)
    laplacian = cv2.Laplacian(equalised, cv2.CV_32F)
    return float(cv2.meanStdDev(laplacian[y0:y1, x0:x1])[1][0, 0] ** 2)


def blur_problem(value: float, limits: QualityLimits = QualityLimits()) -> str:
    """The reason to refuse a face of this :func:`sharpness`, or ``""``."""
    if value >= limits.min_sharpness:
        return ""
    return (f"{BLURRED}: sharpness {value:.0f} (at least {limits.min_sharpness:g}; out of "
            f"focus, moving, or too few pixels)")
