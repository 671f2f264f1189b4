"""The head model adapted to one person from the frames seen: structure from motion.

A mean head model is off by several millimetres in depth for any one face,
and the error shows as a pose error that grows with the turn (a few degrees of
pitch at 60 degrees of yaw on the synthetic head). Seen under several poses,
the fixed landmarks' 3D positions become observable. :class:`OnlineCalibration`
keeps the frames whose pose was reliable, one per pose cell, and every
``every`` new reliable frames re-triangulates each inner model point from them
(a Gauss-Newton step per point on its reprojection error over the kept
frames, with a Gaussian prior of ``prior_mm`` around the mean model), aligns
the refined shape back onto the mean model (rotation and translation, so the
head frame, and with it the meaning of roll, pitch and yaw, stays the mean
model's; scale 1, as one camera cannot tell size from distance) and
re-estimates the kept frames' poses with it, a few rounds. Later frames are
estimated with the refined model; the outline (jaw) stays the mean model's.

The refinement (0.2 to 0.5 s) runs off the per-frame path, in a background
thread; its model is swapped in atomically when done, and a :meth:`reset` in
the meantime (a lost face: another person may come) discards it. A refinement
that fails resets the calibration.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from aamcore.pose.align import align_points
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel, openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.robust import ContourPose, ContourPoseEstimate
from aamcore.pose.rotation import rpy_from_rotation

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class KeptFrame:
    """A frame kept for the refinement.

    Attributes
    ----------
    landmarks : (68, 2) array
        Pixels, NaN where missing.
    camera : CameraIntrinsics
    R, T : (3, 3) and (3,) arrays
        Its pose under the current model.
    weights : (68,) array
        The landmarks' final weights in that estimate.
    """

    landmarks: np.ndarray
    camera: CameraIntrinsics
    R: np.ndarray
    T: np.ndarray
    weights: np.ndarray


@dataclass(frozen=True)
class CalibrationSettings:
    """How :class:`OnlineCalibration` learns the face.

    Attributes
    ----------
    prior_mm : float
        Standard deviation of the prior on each point's offset from the mean model.
    noise_px : float
        Assumed landmark noise, pixels (weighs the data against the prior).
    every : int
        Refine after this many new reliable frames.
    max_frames : int
        Frames kept (one per pose cell; the oldest cell goes first).
    cell_deg : float
        Pose cells: yaw and pitch rounded to this.
    min_frames : int
        Refine only with at least this many kept frames.
    rounds : int
        Triangulate-then-re-estimate rounds per refinement.
    """

    prior_mm: float = 4.0
    noise_px: float = 2.0
    every: int = 10
    max_frames: int = 60
    cell_deg: float = 5.0
    min_frames: int = 10
    rounds: int = 3


def triangulate(frames: list[KeptFrame], inner: np.ndarray, X: np.ndarray, X0: np.ndarray,
                prior_mm: float, noise_px: float) -> np.ndarray:
    """One Gauss-Newton step per model point on its reprojection error, with the prior.

    Parameters
    ----------
    frames : list of KeptFrame
    inner : (n,) int array
        The landmarks refined.
    X, X0 : (n, 3) arrays
        Their current and their mean positions, mm.
    prior_mm, noise_px : float
        See :class:`CalibrationSettings`.

    Returns
    -------
    (n, 3) array
    """
    n = len(inner)
    H = np.tile(np.eye(3) / prior_mm**2, (n, 1, 1))
    g = (X - X0) / prior_mm**2
    for f in frames:
        time.sleep(0)  # give up the GIL (see _reestimated)
        Q = X @ f.R.T + f.T
        z = Q[:, 2]
        pts = f.landmarks[inner]
        ok = np.all(np.isfinite(pts), axis=1) & (z > 0)
        w = f.weights[inner] * ok
        if not w.any():
            continue
        obs = np.zeros((n, 2))
        obs[ok] = f.camera.normalize(pts[ok])
        fx, fy = f.camera.focal
        u, v = Q[:, 0] / z, Q[:, 1] / z
        r = np.stack([(u - obs[:, 0]) * fx, (v - obs[:, 1]) * fy], axis=1)
        dq = np.zeros((n, 2, 3))  # d(u, v)/dQ, then times R
        dq[:, 0, 0] = fx / z
        dq[:, 0, 2] = -fx * u / z
        dq[:, 1, 1] = fy / z
        dq[:, 1, 2] = -fy * v / z
        J = dq @ f.R
        s = w[:, None, None] / noise_px**2
        H += s * np.einsum("nki,nkj->nij", J, J)
        g += (w / noise_px**2)[:, None] * np.einsum("nki,nk->ni", J, r)
    return X - np.linalg.solve(H, g[..., None])[..., 0]


def refine_model(
    frames: dict[Any, KeptFrame], mean: ContourPose, start: np.ndarray,
    settings: CalibrationSettings, options: dict[str, Any],
) -> tuple[np.ndarray, ContourPose, dict[Any, KeptFrame]]:
    """Re-triangulate the inner points from the kept frames and re-estimate their poses.

    Parameters
    ----------
    frames : dict of cell to KeptFrame
    mean : ContourPose
        The estimator of the mean model (its points, inner landmarks, outline).
    start : (68, 3) array
        The current model points, mm.
    settings : CalibrationSettings
    options : dict
        Keyword arguments of every :class:`ContourPose`.

    Returns
    -------
    points : (68, 3) array
        The refined model, in the mean model's frame and size.
    estimator : ContourPose
        On the refined model.
    frames : dict
        The kept frames with their poses under the refined model.
    """
    inner, X0 = mean.inner, mean.X[mean.inner]
    X = start[inner].copy()
    points, estimator = start, mean
    for _ in range(settings.rounds):
        X = triangulate(list(frames.values()), inner, X, X0, settings.prior_mm,
                        settings.noise_px)
        X = align_points(X, X0).apply(X)  # back into the mean model's frame and size
        if not np.all(np.isfinite(X)):
            raise PoseError("the refined head model is not finite")
        points = mean.X.copy()
        points[inner] = X
        model = HeadModel(f"{mean.model.name}+calibrated", "ibug68", 68, np.arange(68), points,
                          "refined from tracked frames")
        estimator = ContourPose(model, outline=mean.outline, **options)
        frames = {cell: _reestimated(estimator, f) for cell, f in frames.items()}
    return points, estimator, frames


def _reestimated(estimator: ContourPose, frame: KeptFrame) -> KeptFrame:
    # Give up the GIL between frames: in a background refinement the per-frame path
    # would otherwise wait up to a switch interval (5 ms) at each of its steps.
    time.sleep(0)
    try:
        e = estimator.estimate(frame.landmarks, frame.camera)
    except PoseError:
        return frame
    return dataclasses.replace(frame, R=e.R, T=e.T, weights=e.weights.copy())


class OnlineCalibration:
    """A :class:`ContourPose` whose head model adapts to the person being tracked.

    Call :meth:`estimate` per fit, in time order; :meth:`reset` when the person
    may have changed (a lost face).

    Parameters
    ----------
    base : HeadModel, optional
        Mean model (default :func:`openface68`).
    settings : CalibrationSettings, optional
    background : bool
        Refine in a background thread (the per-frame path only starts it);
        False refines within the :meth:`estimate` call that makes it due.
    options : dict, optional
        Passed to every :class:`ContourPose`.

    Attributes
    ----------
    current : ContourPose
        The estimator of the latest model; replaced, never changed.
    points : (68, 3) array
        The latest model's points, mm.
    refinements : int
        Refinements swapped in since the last reset.
    """

    def __init__(self, base: HeadModel | None = None,
                 settings: CalibrationSettings | None = None, *, background: bool = True,
                 options: dict[str, Any] | None = None) -> None:
        self.base = base or openface68()
        self.settings = settings or CalibrationSettings()
        self.background = background
        self.options = dict(options or {})
        self._mean = ContourPose(self.base, **self.options)
        self._lock = threading.Lock()
        self._worker: threading.Thread | None = None
        self._generation = 0
        self.failures = 0
        self.reset()

    @property
    def model(self) -> HeadModel:
        """The mean head model."""
        return self._mean.model

    def reset(self) -> None:
        """Forget the person: back to the mean model; a refinement under way is discarded."""
        with self._lock:
            self._generation += 1
            self.current = self._mean
            self.points = self._mean.X.copy()
            self._cells: dict[tuple[int, int], KeptFrame] = {}
            self._since = 0
            self.refinements = 0

    @property
    def pending(self) -> bool:
        """Whether a refinement is running."""
        worker = self._worker
        return worker is not None and worker.is_alive()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the refinement under way, if any; whether none is running now."""
        worker = self._worker
        if worker is not None:
            worker.join(timeout)
        return not self.pending

    def estimate(self, landmarks: np.ndarray, camera: CameraIntrinsics, learn: bool = True,
                 start: tuple[np.ndarray, np.ndarray] | None = None) -> ContourPoseEstimate:
        """Estimate with the current model; keep the frame; start a refinement when due.

        Parameters
        ----------
        landmarks : (68, 2) array
            Pixels.
        camera : CameraIntrinsics
        learn : bool
            Keep the frame if its pose is reliable (False: a fit not to learn from).
        start : (R, T), optional
            A pose to start from (:meth:`ContourPose.estimate`).

        Raises
        ------
        PoseError
            As :meth:`ContourPose.estimate`.
        """
        est = self.current.estimate(landmarks, camera, start)
        if learn and est.reliable:
            self._keep(np.array(landmarks, np.float64), camera, est)
            s = self.settings
            if self._since >= s.every and len(self._cells) >= s.min_frames and not self.pending:
                self._since = 0
                self._start_refinement()
        return est

    def _keep(self, landmarks: np.ndarray, camera: CameraIntrinsics,
              est: ContourPoseEstimate) -> None:
        rpy = rpy_from_rotation(est.R)
        size = self.settings.cell_deg
        cell = (int(round(rpy.yaw / size)), int(round(rpy.pitch / size)))
        with self._lock:
            # A cell's new frame makes it the newest: the cell seen longest ago goes first.
            self._cells.pop(cell, None)
            self._cells[cell] = KeptFrame(landmarks, camera, est.R, est.T, est.weights.copy())
            while len(self._cells) > self.settings.max_frames:
                self._cells.pop(next(iter(self._cells)))
            self._since += 1

    def _start_refinement(self) -> None:
        with self._lock:
            job = (dict(self._cells), self.points.copy(), self._generation)
        if not self.background:
            self._refine(*job)
            return
        self._worker = threading.Thread(target=self._refine, args=job, daemon=True,
                                        name="pose-calibration")
        self._worker.start()

    def _refine(self, frames: dict[tuple[int, int], KeptFrame], start: np.ndarray,
                generation: int) -> None:
        """Refine from a snapshot of the kept frames; swap the result in unless reset since."""
        time.sleep(0)  # a new thread holds the GIL: let the estimate that started it finish
        try:
            points, estimator, refined = refine_model(frames, self._mean, start, self.settings,
                                                      self.options)
        except (ValueError, np.linalg.LinAlgError) as exc:
            # Frames no one head explains (another person among them?): start afresh.
            self.failures += 1
            log.warning("head model refinement failed, back to the mean model: %s", exc)
            if generation == self._generation:
                self.reset()
            return
        with self._lock:
            if generation != self._generation:
                return
            self.points, self.current = points, estimator
            for cell, old in frames.items():
                if self._cells.get(cell) is old:
                    self._cells[cell] = refined[cell]
            self.refinements += 1
