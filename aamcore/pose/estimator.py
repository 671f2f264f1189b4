"""Head pose from a face's landmarks and the frame they were found in, as the stack does it.

:class:`Cameras` gives the intrinsics of any frame size, from a calibration
(scaled to the frame) or from an assumed field of view; :class:`HeadPoseEstimator`
runs one of the estimators of :data:`aamcore.defaults.POSE_ESTIMATORS` on the
landmarks: ContourPose (the default), POSIT on the points without the jaw, or
ContourPose with a head model calibrated to the person. The pose service and
:class:`aamcore.tracker.FaceTracker` both call it, so the library and the
stack give the same numbers.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from aamcore import defaults
from aamcore.pose.calibrate import OnlineCalibration
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel, openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import PoseEstimate
from aamcore.pose.robust import ContourPose, ContourPoseEstimate

POSE_SUBSET = "no_jaw"
"""The head model's points for ``posit``: without the jaw outline. On tracked AAM fits of rendered
sweeps (bench/bench_pose_e2e.py) it gave error sd roll 1.33, pitch 1.56, yaw 3.71 deg,
1.17 cm against 1.64 / 2.68 / 4.55 / 1.33 keeping it: an AAM's jaw points slide along
the outline as the head turns."""


class Cameras:
    """The camera intrinsics for each frame size, from a calibration or an assumed FOV.

    Parameters
    ----------
    fov : float
        Horizontal field of view in degrees, used without a calibration.
    calibration : str, optional
        A calibration file (:meth:`CameraIntrinsics.from_file`), scaled to
        frames of another size than its own.

    Raises
    ------
    IntrinsicsError
        When the calibration cannot be read or is not valid.
    """

    def __init__(self, fov: float = defaults.FOV_DEG, calibration: str | None = None) -> None:
        self.fov = fov
        self.calibration = CameraIntrinsics.from_file(calibration) if calibration else None
        self.source = (f"calibration:{Path(calibration).name}" if calibration
                       else f"assumed:fov{fov:g}")
        self._cache: dict[tuple[int, int], CameraIntrinsics] = {}

    def at(self, width: int, height: int) -> CameraIntrinsics:
        """Intrinsics for frames of ``width`` x ``height`` pixels."""
        cam = self._cache.get((width, height))
        if cam is None:
            if self.calibration is None:
                cam = CameraIntrinsics.from_fov(width, height, self.fov)
            elif (self.calibration.width, self.calibration.height) == (width, height):
                cam = self.calibration
            else:
                cam = self.calibration.scaled_to(width, height)
            self._cache[(width, height)] = cam
        return cam


@dataclass(frozen=True, eq=False)
class HeadPose:
    """A head pose and the camera it is expressed for.

    Attributes
    ----------
    estimate : PoseEstimate
        ``R`` (3, 3) model-to-camera, ``T`` (3,) in millimetres, ``reliable``
        and, when it is not, the ``reason``.
    camera : CameraIntrinsics
    """

    estimate: PoseEstimate
    camera: CameraIntrinsics

    def with_rotation(self, R: np.ndarray, T: np.ndarray) -> HeadPose:
        """The same pose with rotation ``R`` (3, 3) and translation ``T`` (3,) (smoothed)."""
        estimate = copy.copy(self.estimate)  # dataclasses.replace, without its overhead
        object.__setattr__(estimate, "R", R)
        object.__setattr__(estimate, "T", T)
        return HeadPose(estimate, self.camera)

    @property
    def reason(self) -> str:
        """Why the pose is unreliable; empty when it is reliable."""
        return "" if self.estimate.reliable else self.estimate.reason

    @property
    def angle_sd_deg(self) -> float:
        """The largest predicted sd of roll, pitch and yaw, degrees; NaN when not known."""
        est = self.estimate
        if isinstance(est, ContourPoseEstimate):
            sds = est.angle_sd_deg.tolist()
            if all(map(math.isfinite, sds)):
                return max(sds)
        return float("nan")


class HeadPoseEstimator:
    """Head pose of 68-point (iBUG) landmarks with the OpenFace mean head.

    Parameters
    ----------
    cameras : Cameras, optional
        Assumed field of view :data:`aamcore.defaults.FOV_DEG` by default.
    model : HeadModel, optional
        The OpenFace mean head by default (without the jaw outline for ``posit``).
    method : str
        One of :data:`aamcore.defaults.POSE_ESTIMATORS` (default
        :data:`aamcore.defaults.POSE_ESTIMATOR`).

    Raises
    ------
    PoseError
        For an unknown method, or a model the method cannot use.
    """

    def __init__(self, cameras: Cameras | None = None, model: HeadModel | None = None,
                 method: str = defaults.POSE_ESTIMATOR) -> None:
        if method not in defaults.POSE_ESTIMATORS:
            raise PoseError(f"unknown pose estimator {method!r}; choose from "
                            f"{', '.join(defaults.POSE_ESTIMATORS)}")
        self.cameras = cameras or Cameras()
        self.method = method
        self.calibration: OnlineCalibration | None = None
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        if method == "posit":
            self.model = model or openface68(rigid_subset=POSE_SUBSET)
            posit = self.model.posit()
            self._estimate = lambda lm, cam, learn, start: posit.estimate(self.model.select(lm),
                                                                          cam)
        elif method == "contour":
            contour = ContourPose(model)
            self.model = contour.model
            self._estimate = lambda lm, cam, learn, start: contour.estimate(lm, cam, start)
        else:
            self.calibration = OnlineCalibration(model)
            self.model = self.calibration.model
            self._estimate = self.calibration.estimate

    def estimate(self, landmarks: np.ndarray, width: int, height: int, learn: bool = True
                 ) -> HeadPose:
        """The pose of ``landmarks`` (68, 2) found in a frame of ``width`` x ``height``.

        ``learn=False`` keeps ``contour+calib`` from learning the face from this
        fit (one that failed its test). The contour methods start from the face's previous
        pose (from POSIT's answer after :meth:`reset`, a failed estimate, or when the
        previous pose does not lead to a reliable one): an estimator follows one face.

        Raises
        ------
        PoseError
            When the landmarks give no pose (too few usable points, mostly out of
            the frame, not fitting the head model).
        IntrinsicsError
            For a frame size the camera cannot have.
        """
        camera = self.cameras.at(width, height)
        start, self._last = self._last, None
        try:
            estimate = self._estimate(np.asarray(landmarks, np.float64), camera, learn, start)
        except (cv2.error, np.linalg.LinAlgError) as exc:
            # Degenerate input the checks let through (landmarks within a pixel or two):
            # no pose, with the solver's complaint, rather than a crash.
            first = str(exc).strip().splitlines()[-1][:160] if str(exc).strip() else ""
            raise PoseError(f"no pose: the solver failed on these landmarks "
                            f"({type(exc).__name__}: {first})") from exc
        if estimate.converged:
            self._last = (estimate.R, estimate.T)
        return HeadPose(estimate, camera)

    def reset(self) -> None:
        """Forget the face: its last pose (``contour+calib``: back to the mean head model)."""
        self._last = None
        if self.calibration is not None:
            self.calibration.reset()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for a head model refinement under way; whether none is running now."""
        return self.calibration is None or self.calibration.wait(timeout)


class HeadPoseTracker:
    """The head pose of each frame's landmarks, smoothed over time if asked.

    The pose service and :class:`aamcore.tracker.FaceTracker` both use it.

    Parameters
    ----------
    estimator : HeadPoseEstimator
    smooth : bool
        Smooth rotation and translation (:class:`aamcore.pose.smoothing.PoseSmoother`).
    """

    def __init__(self, estimator: HeadPoseEstimator, smooth: bool = False) -> None:
        from aamcore.pose.smoothing import PoseSmoother

        self.estimator = estimator
        self.smoother = PoseSmoother() if smooth else None

    def reset(self) -> None:
        """Forget the face: the smoothing, and what the estimator learned of it."""
        self.estimator.reset()
        if self.smoother is not None:
            self.smoother.reset()

    def update(self, landmarks: np.ndarray, width: int, height: int, t: float,
               fit_failed: bool = False) -> HeadPose:
        """The pose of ``landmarks`` (68, 2) seen at ``t`` seconds in a ``width`` x ``height``
        frame; a failed fit (a lost face) starts the smoothing and the estimator afresh.

        Raises
        ------
        PoseError, IntrinsicsError
            As :meth:`HeadPoseEstimator.estimate`; the smoothing starts afresh (what the
            estimator learned of the face is kept: one unusable fit does not lose it).
        """
        if fit_failed:
            self.reset()
        try:
            pose = self.estimator.estimate(landmarks, width, height, learn=not fit_failed)
        except ValueError:
            if self.smoother is not None:
                self.smoother.reset()
            raise
        if self.smoother is None:
            return pose
        R, T = self.smoother(pose.estimate.R, pose.estimate.T, t)
        return pose.with_rotation(R, T)
