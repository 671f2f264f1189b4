"""When a head pose from landmarks should not be trusted, and why.

:class:`ReliabilityLimits` holds the checks :class:`aamcore.pose.robust.ContourPose`
runs on its answer; :meth:`ReliabilityLimits.problem` returns the first one
that fails as a sentence (its text before the first colon is a short key, for
counting), or ``""`` for a pose to trust. A wrong pose that is called
reliable is worse than no pose: the glasses are drawn in the wrong place.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from aamcore.pose.rotation import rpy_from_rotation


def reason_key(reason: str) -> str:
    """The short key of a reason, to count reasons by: its text before the first colon,
    numbers as ``#``, at most 60 characters."""
    return re.sub(r"\d+", "#", reason.split(":", 1)[0]).strip()[:60]


@dataclass(frozen=True)
class FitQuality:
    """What a pose estimate knows about how well the landmarks fit it.

    Attributes
    ----------
    rms_px : float
        Weighted RMS residual, pixels.
    size_px : float
        Face size: RMS distance of the inner landmarks from their mean, pixels.
    inlier_fraction : float
        Share of the used points within the robust threshold.
    outside_fraction : float
        Share of the landmarks outside the frame or not finite.
    angle_sd_deg : (3,) array
        Predicted standard deviation of roll, pitch and yaw, degrees.
    converged : bool
    """

    rms_px: float
    size_px: float
    inlier_fraction: float
    outside_fraction: float
    angle_sd_deg: np.ndarray
    converged: bool


@dataclass(frozen=True)
class ReliabilityLimits:
    """The checks of a pose estimate, in the order they are made.

    Attributes
    ----------
    max_abs_yaw_deg : float
        Beyond this yaw the face is in profile: half the landmarks are guesses.
    max_outside_fraction : float
        At most this share of the landmarks outside the frame or missing.
    max_relative_rms : float
        Weighted RMS residual at most this fraction of the face size.
    min_inlier_fraction : float
        At least this share of the used points are inliers.
    max_angle_sd_deg : float
        Every predicted angle sd at most this.
    """

    max_abs_yaw_deg: float = 75.0
    max_outside_fraction: float = 0.15
    max_relative_rms: float = 0.1
    min_inlier_fraction: float = 0.6
    max_angle_sd_deg: float = 3.0

    def problem(self, R: np.ndarray, T: np.ndarray, quality: FitQuality) -> str:
        """Why the pose ``R`` (3, 3), ``T`` (3,) (mm) is not to be trusted; ``""`` if it is."""
        if not (np.isfinite(R).all() and np.isfinite(T).all()) or T[2] <= 0:
            return "no valid pose: the head would be behind the camera"
        if float(R[:, 2] @ T) < 0:
            return "the model faces away from the camera: left and right landmarks swapped?"
        yaw = rpy_from_rotation(R).yaw
        if abs(yaw) > self.max_abs_yaw_deg:
            return (f"profile: yaw {yaw:+.0f} deg beyond +-{self.max_abs_yaw_deg:g}, half the "
                    "landmarks are guesses")
        q = quality
        if q.outside_fraction > self.max_outside_fraction:
            return (f"points outside the frame or missing: {100 * q.outside_fraction:.0f} % of "
                    f"the landmarks (limit {100 * self.max_outside_fraction:.0f} %)")
        if not q.rms_px <= self.max_relative_rms * q.size_px:
            return (f"landmarks do not fit the head: residual {q.rms_px:.1f} px is "
                    f"{q.rms_px / q.size_px:.2f} of the face size "
                    f"(limit {self.max_relative_rms:g})")
        if q.inlier_fraction < self.min_inlier_fraction:
            return (f"too many outlying landmarks: {100 * q.inlier_fraction:.0f} % inliers "
                    f"(limit {100 * self.min_inlier_fraction:.0f} %)")
        if not all(sd <= self.max_angle_sd_deg for sd in np.asarray(q.angle_sd_deg).tolist()):
            return (f"poorly determined: predicted angle sd {np.max(q.angle_sd_deg):.1f} deg "
                    f"(limit {self.max_angle_sd_deg:g})")
        if not q.converged:
            return "did not converge"
        return ""
