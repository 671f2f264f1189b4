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
the inner points, re-matching the outline and re-predicting visibility at
each step. The result carries a predicted standard deviation of each angle
(from the Gauss-Newton normal matrix and the residual scale) and is flagged
unreliable, with the reason, by :class:`aamcore.pose.reliability.ReliabilityLimits`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from aamcore.pose.contour import OutlineModel, surrey_outline
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel, openface68
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import PoseEstimate, Posit
from aamcore.pose.refine import _skew_exp, reprojection_rows
from aamcore.pose.reliability import FitQuality, ReliabilityLimits
from aamcore.pose.visibility import landmark_normals, visibility_weights

INNER_NO_INNER_MOUTH = tuple(range(17, 60))
"""Brows, nose, eyes and outer lips."""
INNER_RIGID = tuple(range(27, 48)) + (48, 54)
"""Nose, eyes and mouth corners: the default fixed points. Brows and lips move
with expression and their markup varies most between annotators and trackers."""
MIN_POINTS = 6
BEHIND = "no valid pose: part of the head would be behind the camera"


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
        max_iterations: int = 8, outside_margin: float = 0.05,
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
        self.outside_margin = float(outside_margin)
        self.limits = limits or ReliabilityLimits()
        self._posit = Posit(self.X[self.inner], refine_iterations=0)

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
        finite = np.all(np.isfinite(pts), axis=1)
        inner_ok = finite[self.inner]
        if inner_ok.sum() < MIN_POINTS:
            raise PoseError(f"too few landmarks: only {int(inner_ok.sum())} finite inner "
                            f"landmarks, need {MIN_POINTS}")
        used = pts[self.inner][inner_ok]
        size = float(np.sqrt(np.mean(np.sum((used - used.mean(axis=0)) ** 2, axis=1))))
        if not size > 0:
            raise PoseError("degenerate landmarks: the inner landmarks all coincide")
        inside = finite
        if cam.width > 0 and cam.height > 0:
            m = self.outside_margin * size
            with np.errstate(invalid="ignore"):
                inside = finite & ((pts[:, 0] >= -m) & (pts[:, 0] <= cam.width - 1 + m)
                                   & (pts[:, 1] >= -m) & (pts[:, 1] <= cam.height - 1 + m))
        if inside[self.inner].sum() < MIN_POINTS:
            raise PoseError(f"mostly out of the frame: only {int(inside[self.inner].sum())} "
                            f"inner landmarks inside the image, need {MIN_POINTS}")
        xy = np.full((68, 2), np.nan)
        xy[finite] = cam.normalize(pts[finite])
        return _Seen(xy, inside, np.array(cam.focal, dtype=np.float64), size,
                     float(1.0 - inside.mean()))

    # -- estimate ------------------------------------------------------------------------
    def estimate(self, landmarks: np.ndarray, camera: CameraIntrinsics | np.ndarray
                 ) -> ContourPoseEstimate:
        """Estimate the head pose from one fit's landmarks.

        Parameters
        ----------
        landmarks : (68, 2) array
            iBUG-68 landmarks, pixels. Non-finite points are left out.
        camera : CameraIntrinsics or (3, 3) array
            With the image size, landmarks outside the frame are left out too.

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
        R, T = self._start(seen, cam)
        R, T, iterations, converged = self._refine(R, T, seen)
        return self._result(R, T, seen, iterations, converged)

    def _start(self, seen: _Seen, cam: CameraIntrinsics) -> tuple[np.ndarray, np.ndarray]:
        """POSIT on the usable inner points (SQPNP if POSIT does not converge)."""
        use = seen.inside[self.inner]
        inner_xy = seen.xy[self.inner]
        try:
            # POSIT takes pixels through the intrinsics: rebuild them from xy (no distortion).
            uv = np.where(use[:, None], inner_xy, 0.0) @ cam.K[:2, :2].T + cam.K[:2, 2]
            est = self._posit.estimate(uv, CameraIntrinsics(cam.K),
                                       None if use.all() else use.astype(np.float64))
            if est.converged and np.all(np.isfinite(est.R)):
                return est.R, est.T
        except PoseError:
            pass
        _, rvec, tvec = cv2.solvePnP(self.X[self.inner][use], inner_xy[use], np.eye(3), None,
                                     flags=cv2.SOLVEPNP_SQPNP)
        return cv2.Rodrigues(rvec)[0], tvec.ravel()

    def _system(self, R: np.ndarray, T: np.ndarray, seen: _Seen
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """Residuals (px), Jacobian (rows, 6), base weights and outline points at a pose.

        Inner points give an x and a y row each, outline points one row across
        the outline. None when a point is at or behind the camera.
        """
        inner, jaw = self.inner, self._jaw
        w_in = seen.inside[inner].astype(np.float64)
        if self.normals is not None:
            w_in = w_in * visibility_weights(self.X[inner], self.normals[inner], R, T,
                                             *self.ramp_deg)
        obs = np.where(np.isfinite(seen.xy), seen.xy, 0.0)
        if self.outline is None:
            rows = reprojection_rows(R, T, self.X[inner], obs[inner], seen.fxy)
            return None if rows is None else (*rows, np.concatenate([w_in, w_in]),
                                              np.zeros((0, 3)))
        S, d, _ = self.outline.silhouette(R, T, np.diag([*seen.fxy, 1.0]))
        rows = reprojection_rows(R, T, np.vstack([self.X[inner], S]),
                                 np.vstack([obs[inner], obs[jaw]]), seen.fxy)
        if rows is None:
            return None
        r_all, J_all = rows
        n, L = len(inner), len(jaw)
        x_in, y_in = slice(0, n), slice(n + L, 2 * n + L)
        x_jaw, y_jaw = slice(n, n + L), slice(2 * n + L, None)
        r = np.concatenate([r_all[x_in], r_all[y_in],
                            r_all[x_jaw] * d[:, 0] + r_all[y_jaw] * d[:, 1]])
        J = np.vstack([J_all[x_in], J_all[y_in],
                       J_all[x_jaw] * d[:, :1] + J_all[y_jaw] * d[:, 1:]])
        w_jaw = self.outline_weight * seen.inside[jaw].astype(np.float64)
        return r, J, np.concatenate([w_in, w_in, w_jaw]), S

    def _robust(self, r: np.ndarray, w_base: np.ndarray, floor: float) -> np.ndarray:
        """Huber weights (rows,) of the residuals ``r``, scale from the used ones."""
        if self.huber is None:
            return np.ones_like(r)
        used = w_base > 0
        scale = floor
        if used.any():
            scale = max(1.4826 * float(np.median(np.abs(r[used]))), floor)
        a = np.abs(r) / (self.huber * scale)
        return np.where(a <= 1.0, 1.0, 1.0 / np.maximum(a, 1e-12))

    def _refine(self, R: np.ndarray, T: np.ndarray, seen: _Seen
                ) -> tuple[np.ndarray, np.ndarray, int, bool]:
        """Reweighted Gauss-Newton steps: the pose, steps taken and whether it settled."""
        floor = self.scale_floor * seen.size
        last_step = np.inf
        iterations = 0
        for iterations in range(1, self.max_iterations + 1):  # noqa: B007
            system = self._system(R, T, seen)
            if system is None:
                return R, T, iterations, False
            r, J, w_base, _ = system
            w = w_base * self._robust(r, w_base, floor)
            Jw = J * w[:, None]
            try:
                step = np.linalg.solve(J.T @ Jw + 1e-9 * np.eye(6), -(Jw.T @ r))
            except np.linalg.LinAlgError:
                break
            R = _skew_exp(step[:3]) @ R
            T = T + step[3:]
            last_step = float(np.abs(step[:3]).max())
            if last_step < 1e-4 and np.abs(step[3:]).max() < 0.05:
                return R, T, iterations, True
        # Reweighting can make the last steps dither: a pose still moving by less
        # than 0.1 degree per step has settled.
        return R, T, iterations, last_step < np.radians(0.1)

    def _result(self, R: np.ndarray, T: np.ndarray, seen: _Seen, iterations: int,
                converged: bool) -> ContourPoseEstimate:
        """The estimate at the final pose: weights, predicted sd, reliability."""
        system = self._system(R, T, seen)
        if system is None:
            return ContourPoseEstimate(R, T, iterations, False, False, BEHIND, float("inf"),
                                       outside_fraction=seen.outside_fraction)
        r, J, w_base, outline_pts = system
        robust_w = self._robust(r, w_base, self.scale_floor * seen.size)
        w = w_base * robust_w
        used = w_base > 0
        wsum = float(w.sum())
        rms = float(np.sqrt((w @ (r * r)) / wsum)) if wsum > 0 else float("inf")
        inliers = float(np.mean(robust_w[used] >= 1.0)) if used.any() else 0.0
        angle_sd, dist_sd = _predicted_sd(J, w, r, float(used.sum()), T)
        n = len(self.inner)
        weights = np.zeros(68)
        weights[self.inner] = w_base[:n] * np.minimum(robust_w[:n], robust_w[n:2 * n])
        weights[self._jaw] = w[2 * n:]
        quality = FitQuality(rms, seen.size, inliers, seen.outside_fraction, angle_sd, converged)
        reason = self.limits.problem(R, T, quality)
        return ContourPoseEstimate(
            R, T, iterations, converged, reason == "", reason or "ok", rms, angle_sd, dist_sd,
            weights, outline_pts, inliers, seen.outside_fraction)


def _predicted_sd(J: np.ndarray, w: np.ndarray, r: np.ndarray, n_used: float, T: np.ndarray
                  ) -> tuple[np.ndarray, float]:
    """Predicted sd of roll, pitch, yaw (3,) in degrees and of the distance (mm).

    From the weighted Gauss-Newton normal matrix ``J^T W J`` (rows, 6) and the
    residual variance; infinite when the pose is not determined.
    """
    sigma2 = (w @ (r * r)) / max(n_used - 6.0, 1.0)
    try:
        cov = np.linalg.inv(J.T @ (J * w[:, None])) * sigma2
    except np.linalg.LinAlgError:
        return np.full(3, np.inf), float("inf")
    sd_rot = np.degrees(np.sqrt(np.clip(np.diag(cov)[:3], 0.0, None)))
    u = T / np.linalg.norm(T)
    # The rotation vector's camera axes x, y, z are pitch, yaw and roll.
    return sd_rot[[2, 0, 1]], float(np.sqrt(max(u @ cov[3:, 3:] @ u, 0.0)))
