"""What passes from one stage to the next, for one frame: the frame's reference, each face's
fit and pose. The library's chain hands them on; a service makes them from its messages."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aamcore.fitting.result import AAMFit, LandmarkFit, appearance_of

NO_FACE = "no face"
"""The reason of a frame without a face."""
NOBODY = -1
"""The ``face_id`` of a frame without a tracked face (its one entry: a failed fit, or none)."""


@dataclass(frozen=True)
class FrameRef:
    """The frame a stage's inputs belong to.

    Attributes
    ----------
    index : int
        Frame index in its stream (an index that does not follow the last starts afresh).
    t : float
        Media time, seconds (the smoothers' clock).
    width, height : int
        Pixels.
    """

    index: int
    t: float
    width: int
    height: int


@dataclass(frozen=True, eq=False)
class FaceFit:
    """One face's fit in one frame, as the later stages read it.

    Attributes
    ----------
    face_id : int
        The face's id; :data:`NOBODY` for a frame without a tracked face.
    points : (N, 2) array
        Landmarks in pixels (smoothed when the fit stage smooths); ``(0, 2)`` without a face.
    failed : bool
    reason : str
        Why the fit failed (``"no face"`` when nothing was found).
    appearance : (k,) array or None
        The AAM's ``c``.
    occluded : (N,) bool array or None
        Per-landmark occlusion flags.
    scheme : str
        The landmark scheme.
    fit : LandmarkFit or None
        The fitter's result itself (the fit stage's; None when made from a message).
    """

    face_id: int
    points: np.ndarray
    failed: bool
    reason: str
    appearance: np.ndarray | None
    occluded: np.ndarray | None
    scheme: str
    fit: LandmarkFit | None = None

    @classmethod
    def of(cls, face_id: int, fit: LandmarkFit | None, scheme: str) -> FaceFit:
        """The entry of a fitter's result (None: no face found)."""
        if fit is None:
            return cls(face_id, np.zeros((0, 2)), True, NO_FACE, None, None, scheme)
        occluded = fit.occluded if isinstance(fit, AAMFit) else None
        return cls(face_id, fit.points, fit.failed, fit.reason, appearance_of(fit), occluded,
                   scheme, fit)

    @property
    def found(self) -> bool:
        """Whether the fit has landmarks."""
        return len(self.points) > 0


@dataclass(frozen=True, eq=False)
class FacePose:
    """One face's head pose in one frame, or why there is none.

    Attributes
    ----------
    face_id : int
    rotation : (3, 3) array or None
        Model to camera (``X_cam = R X_model + T``); None without a pose.
    translation_mm : (3,) array or None
    angles_deg : (3,) tuple
        Roll, pitch and yaw, degrees (NaN without a pose).
    K : (3, 3) array or None
        The camera matrix the pose is for.
    reliable : bool
        A pose of a good fit that the estimator trusts.
    reason : str
        Why the pose is unreliable (``"fit failed: ..."`` for a failed fit) or why there is
        none; empty for a reliable pose.
    iterations : int
    angle_sd_deg : float
        The largest predicted sd of the angles (NaN where not known).
    camera : str
        Where ``K`` comes from (``assumed:fov60``, ``calibration:cam.yaml``).
    covered : (k, 2) array or None
        Pixels of the fit's landmarks flagged occluded (a hand, an object in front of the
        face): the overlay hides the glasses there. None or empty: nothing covered.
    """

    face_id: int
    rotation: np.ndarray | None = None
    translation_mm: np.ndarray | None = None
    angles_deg: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    K: np.ndarray | None = None
    reliable: bool = False
    reason: str = ""
    iterations: int = 0
    angle_sd_deg: float = math.nan
    camera: str = ""
    covered: np.ndarray | None = None

    @property
    def found(self) -> bool:
        """Whether there is a pose."""
        return self.rotation is not None
