"""Head pose that holds at large yaw: sliding outline, predicted visibility, robust weights.

:class:`ContourPose` estimates the head pose from the 68 iBUG landmarks of
one fit. Like :class:`aamcore.pose.posit.Posit` it uses a rigid 3D head
model (the OpenFace mean shape by default), but it treats the landmarks as a
tracker produces them rather than as fixed points of the face:

- **Inner points** (nose, eyes and mouth corners by default: iBUG 27-47, 48
  and 54) are fixed points of the model; each gives a 2D reprojection residual.
- **Outline points** (the jaw, iBUG 0-16) lie on the face's outline as seen,
  which slides over the skin as the head turns (:mod:`aamcore.pose.contour`).
  Under the current pose each is matched to the silhouette point of its slice
  of a head mesh, and only its distance across the outline counts (one
  residual along the outline's normal), so sliding along the outline costs nothing.
- **Visibility** (:mod:`aamcore.pose.visibility`): a point whose surface turns
  away from the camera (a far-side eye corner at large yaw) loses weight.
- **Robust weights**: Huber weights on the residuals (scale from their
  median absolute value, with a floor tied to the face size) keep one bad
  point from pulling the pose.

The pose is found by iteratively reweighted Gauss-Newton from POSIT's answer on
the inner points (when tracking, from the face's previous pose: one step where the
face moved by less than a degree), re-matching the outline and re-predicting
visibility at each step. The result carries a predicted standard deviation of each angle
(from the Gauss-Newton normal matrix and the residual scale) and is flagged
unreliable, with the reason, by :class:`aamcore.pose.reliability.ReliabilityLimits`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from aamcore.pose.contour import OutlineModel, surrey_outline
from aamcore.pose.contour_rows import ContourRows, RowFrame
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel, openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import PoseEstimate, Posit
from aamcore.pose.reliability import FitQuality, ReliabilityLimits
from aamcore.pose.visibility import landmark_normals

INNER_NO_INNER_MOUTH = tuple(range(17, 60))
"""Brows, nose, eyes and outer lips."""
INNER_RIGID = tuple(range(27, 48)) + (48, 54)
"""Nose, eyes and mouth corners: the default fixed points. Brows and lips move
with expression and their markup varies most between annotators and trackers."""
MIN_POINTS = 6
BEHIND = "no valid pose: part of the head would be behind the camera"
DAMPING = 1e-9 * np.eye(6)
"""Added to the normal matrix of every Gauss-Newton step."""


@dataclass(frozen=True, eq=False)
class ContourPoseEstimate(PoseEstimate):
    """A :class:`PoseEstimate` with what :class:`ContourPose` learned about the landmarks.

    Attributes
    ----------
    angle_sd_deg : (3,) float64 array
        Predicted standard deviation of roll, pitch and yaw (degrees).
    distance_sd_mm : float
        Predicted standard deviation of the distance.
    weights : (68,) float64 array
        Final weight of each landmark (0: not used, hidden or outside the frame).
    outline_points : (L, 3) float64 array
        The model points the outline landmarks were matched to, head frame, mm.
    inlier_fraction : float
        Share of the used points whose residual is within the Huber threshold.
    outside_fraction : float
        Share of the landmarks outside the image or not finite.
    """

    angle_sd_deg: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    distance_sd_mm: float = float("nan")
    weights: np.ndarray = field(default_factory=lambda: np.zeros(68))
    outline_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    inlier_fraction: float = float("nan")
    outside_fraction: float = 0.0


@dataclass(frozen=True, eq=False)
class _Seen:
    """One fit's landmarks, ready for the refinement.

    ``xy`` (68, 2) normalised coordinates (NaN where missing), ``inside`` (68,)
    usable points, ``fxy`` (2,) focal lengths, ``size`` the face size in pixels.
    """

    xy: np.ndarray
    inside: np.ndarray
    fxy: np.ndarray
    size: float
    outside_fraction: float


class ContourPose:
    """Head pose from 68 iBUG landmarks, robust to large yaw (see the module notes).

    Parameters
    ----------
    model : HeadModel, optional
        Full iBUG-68 3D model, mm (default :func:`openface68`).
    inner : sequence of int
        Landmarks used as fixed model points (default :data:`INNER_RIGID`).
    outline : OutlineModel or None or "default"
        Sliding outline for the jaw landmarks: ``"default"`` is
        :func:`aamcore.pose.contour.surrey_outline` on ``model``; None leaves the jaw out.
    outline_weight : float
        Weight of an outline residual relative to an inner point's.
    visibility : bool
        Weight points by their predicted visibility.
    visible_until_deg, hidden_from_deg : float
        The visibility ramp (:func:`aamcore.pose.visibility.visibility_weights`).
    huber : float or None
        Huber threshold in units of the residual scale; None: plain least squares.
    scale_floor : float
        Lower bound of the residual scale, as a fraction of the face size
        (RMS distance of the inner landmarks from their mean).
    max_iterations : int
        Gauss-Newton steps at most.
    step_deg, step_mm : float
        The pose has converged once a step turns it by less than ``step_deg`` about every
        axis and moves it by less than ``step_mm`` (0.1 degree a step is also what "settled"
        means after ``max_iterations``). The reweighting and the sliding outline make the
        steps shrink about fivefold each, so what is left is a few hundredths of a degree:
        on ``bench/bench_pose_yaw.py`` no error sd moved by more than 0.01 against steps
        to 0.006 degree, and tracked faces take 2.3 steps a frame instead of 5.6.
    warm_step_deg, warm_step_mm : float
        From a start pose (the face's previous one), a first step smaller than this is the
        last: a frame's motion costs one step instead of two or three. The step leaves
        about a third of the motion to the next frame's (the robust weights and the
        outline's matches are the start's): on the clip ``videos/single_face.mp4`` the poses
        moved by at most 0.25 degree and 0.7 mm against iterating to convergence, and no
        error sd of ``bench/bench_pose_yaw.py`` by more than 0.05 degree (2.47 -> 2.44 on
        tracked yaw), while the pose stage took 25 % less time beside the fitter.
    outside_margin : float
        A landmark is outside when beyond the image border by more than this
        fraction of the face size.
    limits : ReliabilityLimits
        When the answer is flagged unreliable.

    Raises
    ------
    PoseError
        For a model that is not a full iBUG-68 one or fewer than six inner landmarks.
    """

    def __init__(
        self, model: HeadModel | None = None, *, inner: tuple[int, ...] = INNER_RIGID,
        outline: OutlineModel | None | str = "default", outline_weight: float = 0.5,
        visibility: bool = True, visible_until_deg: float = 65.0,
        hidden_from_deg: float = 90.0, huber: float | None = 2.0, scale_floor: float = 0.01,
        max_iterations: int = 8, step_deg: float = 0.1, step_mm: float = 0.5,
        warm_step_deg: float = 1.0, warm_step_mm: float = 5.0, outside_margin: float = 0.05,
        limits: ReliabilityLimits | None = None,
    ) -> None:
        self.model = model or openface68()
        if self.model.scheme != "ibug68" or len(self.model.indices) != 68:
            raise PoseError(f"ContourPose needs a full iBUG-68 model, got {self.model.name}")
        self.X = self.model.points[np.argsort(self.model.indices)]
        self.inner = np.array(sorted({int(i) for i in inner}), dtype=np.int64)
        if len(self.inner) < MIN_POINTS or self.inner.min() < 0 or self.inner.max() > 67:
            raise PoseError(f"need at least {MIN_POINTS} inner landmarks in 0..67")
        self.outline = self._outline(outline)
        self._jaw = (np.zeros(0, np.int64) if self.outline is None
                     else np.asarray(self.outline.landmarks, dtype=np.int64))
        self.outline_weight = float(outline_weight)
        self.normals = landmark_normals(self.model) if visibility else None
        self.ramp_deg = (float(visible_until_deg), float(hidden_from_deg))
        self.huber = huber
        self.scale_floor = float(scale_floor)
        self.max_iterations = int(max_iterations)
        self.step_tolerance = (float(np.radians(step_deg)), float(step_mm))
        self.warm_tolerance = (float(np.radians(warm_step_deg)), float(warm_step_mm))
        self.outside_margin = float(outside_margin)
        self.limits = limits or ReliabilityLimits()
        self._posit = Posit(self.X[self.inner], refine_iterations=0)
        self._every = np.ones(68, bool)
        self._every.setflags(write=False)
        self._rows = ContourRows(self.inner, self.X[self.inner], None if self.normals is None
                                 else self.normals[self.inner], self.outline, *self.ramp_deg)

    def _outline(self, outline: OutlineModel | None | str) -> OutlineModel | None:
        if not isinstance(outline, str):
            return outline
        if outline != "default":
            raise PoseError(f"outline must be an OutlineModel, None or 'default': {outline}")
        if self.model.name == "openface_mean68":
            return surrey_outline()
        return surrey_outline(np.ascontiguousarray(self.X, np.float64).tobytes())

    # -- input ---------------------------------------------------------------------------
    def _prepare(self, landmarks: np.ndarray, cam: CameraIntrinsics) -> _Seen:
        """Check one fit's landmarks, find the usable ones, normalise them."""
        pts = np.asarray(landmarks, dtype=np.float64)
        if pts.shape != (68, 2):
            raise PoseError(f"not 68 landmarks: need the iBUG-68 points as a (68, 2) array, "
                            f"got shape {pts.shape}")
        every = bool(np.isfinite(pts).all())
        finite = self._every if every else np.isfinite(pts).all(axis=1)
        used = pts[self.inner] if every else pts[self.inner][finite[self.inner]]
        if len(used) < MIN_POINTS:
            raise PoseError(f"too few landmarks: only {len(used)} finite inner "
                            f"landmarks, need {MIN_POINTS}")
        centred = used - np.add.reduce(used) / len(used)
        size = math.sqrt(float(np.einsum("nd,nd->", centred, centred)) / len(used))
        if not size > 0:
            raise PoseError("degenerate landmarks: the inner landmarks all coincide")
        inside = self._inside(pts, finite, cam, self.outside_margin * size)
        n_inside = int(inside[self.inner].sum())
        if n_inside < MIN_POINTS:
            raise PoseError(f"mostly out of the frame: only {n_inside} "
                            f"inner landmarks inside the image, need {MIN_POINTS}")
        if every:
            xy = cam.normalize(pts)
        else:
            xy = np.full((68, 2), np.nan)
            xy[finite] = cam.normalize(pts[finite])
        outside = 0.0 if inside is self._every else float(1.0 - inside.mean())
        return _Seen(xy, inside, np.array(cam.focal, dtype=np.float64), size, outside)

    def _inside(self, pts: np.ndarray, finite: np.ndarray, cam: CameraIntrinsics, margin: float
                ) -> np.ndarray:
        """(68,) bool: the finite landmarks within ``margin`` pixels of the image."""
        if cam.width <= 0 or cam.height <= 0:
            return finite
        high = (cam.width - 1 + margin, cam.height - 1 + margin)
        if finite is self._every:
            (x0, y0), (x1, y1) = pts.min(axis=0).tolist(), pts.max(axis=0).tolist()
            if x0 >= -margin and y0 >= -margin and x1 <= high[0] and y1 <= high[1]:
                return self._every
        return finite & ((pts >= -margin) & (pts <= high)).all(axis=1)

    # -- estimate ------------------------------------------------------------------------
    def estimate(self, landmarks: np.ndarray, camera: CameraIntrinsics | np.ndarray,
                 start: tuple[np.ndarray, np.ndarray] | None = None) -> ContourPoseEstimate:
        """Estimate the head pose from one fit's landmarks.

        Parameters
        ----------
        landmarks : (68, 2) array
            iBUG-68 landmarks, pixels. Non-finite points are left out.
        camera : CameraIntrinsics or (3, 3) array
            With the image size, landmarks outside the frame are left out too.
        start : (R (3, 3), T (3,)), optional
            A pose to start from (the face's previous one): the refinement starts there
            instead of at POSIT's answer, and from POSIT after all when it does not
            settle on a reliable pose from there.

        Returns
        -------
        ContourPoseEstimate
            ``reliable`` is False, with the reason, for a face in profile, a
            residual that the head model cannot explain, too many outliers,
            too many points outside the frame, a poorly determined pose, or a
            model facing away from the camera.

        Raises
        ------
        PoseError
            For a wrong shape or fewer than six usable inner landmarks (no pose).
        """
        cam = camera if isinstance(camera, CameraIntrinsics) else CameraIntrinsics(camera)
        seen = self._prepare(landmarks, cam)
        frame = self._rows.frame(seen.xy, seen.inside, seen.fxy, self.outline_weight)
        if start is not None:
            warm = self._refine(*start, seen, frame, self.warm_tolerance)
            if warm.converged and warm.reliable:
                return warm
        return self._refine(*self._start(seen, cam), seen, frame)

    def _start(self, seen: _Seen, cam: CameraIntrinsics) -> tuple[np.ndarray, np.ndarray]:
        """POSIT on the usable inner points (SQPNP if POSIT does not converge)."""
        use = seen.inside[self.inner]
        inner_xy = seen.xy[self.inner]
        try:
            est = self._posit.estimate_normalised(np.where(use[:, None], inner_xy, 0.0),
                                                  seen.fxy, None if use.all() else
                                                  use.astype(np.float64))
            if est.converged and np.all(np.isfinite(est.R)):
                return est.R, est.T
        except PoseError:
            pass
        _, rvec, tvec = cv2.solvePnP(self.X[self.inner][use], inner_xy[use], np.eye(3), None,
                                     flags=cv2.SOLVEPNP_SQPNP)
        return cv2.Rodrigues(rvec)[0], tvec.ravel()

    def _robust(self, r: np.ndarray, w_base: np.ndarray, floor: float) -> np.ndarray:
        """Huber weights (rows,) of the residuals ``r``, scale from the used ones."""
        if self.huber is None:
            return np.ones_like(r)
        size = np.abs(r)
        used = size[w_base > 0]
        scale = max(1.4826 * _median(used), floor) if len(used) else floor
        return 1.0 / np.maximum(size / (self.huber * scale), 1.0)

    def _refine(self, R: np.ndarray, T: np.ndarray, seen: _Seen, frame: RowFrame,
                first_tolerance: tuple[float, float] | None = None) -> ContourPoseEstimate:
        """Reweighted Gauss-Newton steps from ``R``, ``T``, and the estimate they reach.

        Once a step is small (the first one within ``first_tolerance``, radians and mm,
        where given) the estimate is read from that step's rows, their residuals moved by
        the step (to first order); otherwise from the rows at the last pose.
        """
        floor = self.scale_floor * seen.size
        last_step = np.inf
        iterations = 0
        tol_rad, tol_mm = first_tolerance or self.step_tolerance
        for iterations in range(1, self.max_iterations + 1):  # noqa: B007
            rows = self._rows.at(R, T, frame)
            if rows is None:
                return self._behind(R, T, seen, iterations)
            r, Jt, w_base = rows
            Jw = Jt * (w_base * self._robust(r, w_base, floor))
            H = Jw @ Jt.T
            H += DAMPING
            solved, step = cv2.solve(H, Jw @ -r, flags=cv2.DECOMP_CHOLESKY)
            if not solved:
                break
            R = cv2.Rodrigues(step[:3])[0] @ R
            T = T + step[3:, 0]
            w0, w1, w2, t0, t1, t2 = step[:, 0].tolist()
            last_step = max(abs(w0), abs(w1), abs(w2))
            if last_step < tol_rad and max(abs(t0), abs(t1), abs(t2)) < tol_mm:
                return self._result(R, T, seen, frame, iterations, True,
                                    (r + step[:, 0] @ Jt, Jt, w_base))
            tol_rad, tol_mm = self.step_tolerance
        # Reweighting can make the last steps dither: a pose still moving by less
        # than 0.1 degree per step has settled.
        rows = self._rows.at(R, T, frame)
        if rows is None:
            return self._behind(R, T, seen, iterations)
        return self._result(R, T, seen, frame, iterations, last_step < np.radians(0.1), rows)

    def _behind(self, R: np.ndarray, T: np.ndarray, seen: _Seen, iterations: int
                ) -> ContourPoseEstimate:
        return ContourPoseEstimate(R, T, iterations, False, False, BEHIND, float("inf"),
                                   outside_fraction=seen.outside_fraction)

    def _result(self, R: np.ndarray, T: np.ndarray, seen: _Seen, frame: RowFrame,
                iterations: int, converged: bool, rows: tuple[np.ndarray, np.ndarray, np.ndarray]
                ) -> ContourPoseEstimate:
        """The estimate at the final pose from its rows: weights, predicted sd, reliability."""
        r, Jt, w_base = rows
        robust_w = self._robust(r, w_base, self.scale_floor * seen.size)
        w = w_base * robust_w
        used = w_base > 0
        wsum = float(w.sum())
        rms = math.sqrt(float(w @ (r * r)) / wsum) if wsum > 0 else float("inf")
        n_used = int(np.count_nonzero(used))
        inliers = np.count_nonzero(robust_w[used] >= 1.0) / n_used if n_used else 0.0
        angle_sd, dist_sd = _predicted_sd(Jt, w, r, float(n_used), T)
        n = len(self.inner)
        weights = np.zeros(68)
        weights[self.inner] = w_base[:n] * np.minimum(robust_w[:n], robust_w[n:2 * n])
        weights[self._jaw] = w[2 * n:]
        quality = FitQuality(rms, seen.size, inliers, seen.outside_fraction, angle_sd, converged)
        reason = self.limits.problem(R, T, quality)
        return ContourPoseEstimate(
            R, T, iterations, converged, reason == "", reason or "ok", rms, angle_sd, dist_sd,
            weights, self._rows.outline_points(frame), inliers, seen.outside_fraction)


def _median(values: np.ndarray) -> float:
    """The median of a non-empty 1-D array (:func:`numpy.median`'s value, with less overhead)."""
    half = len(values) // 2
    if len(values) % 2:
        return float(np.partition(values, half)[half])
    low, high = np.partition(values, (half - 1, half))[half - 1:half + 1]
    return 0.5 * float(low + high)


def _predicted_sd(Jt: np.ndarray, w: np.ndarray, r: np.ndarray, n_used: float, T: np.ndarray
                  ) -> tuple[np.ndarray, float]:
    """Predicted sd of roll, pitch, yaw (3,) in degrees and of the distance (mm).

    From the weighted Gauss-Newton normal matrix ``J^T W J`` (``Jt`` (6, rows) the
    Jacobian transposed) and the residual variance; infinite when the pose is not
    determined.
    """
    sigma2 = (w @ (r * r)) / max(n_used - 6.0, 1.0)
    ok, cov = cv2.invert((Jt * w) @ Jt.T, flags=cv2.DECOMP_CHOLESKY)
    if not ok:
        return np.full(3, np.inf), float("inf")
    # The rotation vector's camera axes x, y, z are pitch, yaw and roll.
    pitch, yaw, roll = (math.degrees(math.sqrt(max(v * sigma2, 0.0)))
                        for v in cov.diagonal()[:3].tolist())
    u = T / math.sqrt(T @ T)
    return np.array([roll, pitch, yaw]), math.sqrt(max(float(u @ cov[3:, 3:] @ u) * sigma2, 0.0))
