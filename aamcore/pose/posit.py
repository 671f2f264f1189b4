"""POSIT: Pose from Orthography and Scaling with ITerations (thesis ch. 13, Algorithm 9).

DeMenthon and Davis' algorithm finds the rotation ``R`` and translation ``T``
of a rigid 3D model from the images of at least four non-coplanar model
points. With ``M = [X Y Z 1]`` the (N, 4) model matrix, each iteration solves
the scaled-orthographic system (eq 13.11)::

    [r1/Tz  r2/Tz; Tx/Tz  Ty/Tz] = pinv(M) @ (w * [u v])

for normalised image coordinates ``(u, v)``, sets ``r3 = r1 x r2`` and updates
the perspective correction ``w_i = 1 + r3 . P_i / Tz`` (eq 13.8) until ``w``
stops changing. ``pinv(M)`` depends on the model only, so :class:`Posit`
computes it once.

Plain POSIT solves for ``r1`` and ``r2`` independently (eight unknowns for six
degrees of freedom), which makes it noisier than a maximum-likelihood
estimate. :class:`Posit` therefore finishes, by default, with a few
Gauss-Newton steps on the pixel reprojection error (:mod:`aamcore.pose.refine`),
seeded by POSIT (``refine_iterations=0`` gives the thesis's algorithm alone);
the bench ``bench/bench_posit.py`` measures both.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import isfinite, sqrt

import numpy as np

from aamcore.pose.errors import PoseError
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.refine import gauss_newton
from aamcore.pose.rotation import RPY, nearest_rotation, rpy_from_rotation

MIN_POINTS = 4


@dataclass(frozen=True, eq=False)
class PoseEstimate:
    """A head (model) pose in the camera frame.

    Attributes
    ----------
    R : (3, 3) float64 array
        Model-to-camera rotation: ``X_cam = R @ X_model + T``.
    T : (3,) float64 array
        Model origin in camera coordinates, in the model's units.
    iterations : int
        POSIT iterations run.
    converged : bool
        Whether the POSIT iteration met its tolerance.
    reliable : bool
        False when the estimate should not be trusted; ``reason`` says why.
    reason : str
        ``"ok"`` or why the estimate is unreliable.
    rms_px : float
        Root-mean-square reprojection error of the weighted points, pixels.
    """

    R: np.ndarray
    T: np.ndarray
    iterations: int
    converged: bool
    reliable: bool
    reason: str
    rms_px: float = float("nan")

    @property
    def rpy(self) -> RPY:
        """Roll, pitch and yaw in degrees (eq 14.3, see :mod:`aamcore.pose.rotation`)."""
        return rpy_from_rotation(self.R)

    @property
    def distance(self) -> float:
        """Distance from the camera centre to the model origin, in the model's units."""
        return float(np.sqrt(self.T @ self.T))


def _as_model(points: np.ndarray) -> np.ndarray:
    X = np.asarray(points, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 3:
        raise PoseError(f"model points must have shape (N, 3), got {X.shape}")
    if len(X) < MIN_POINTS:
        raise PoseError(f"POSIT needs at least {MIN_POINTS} points, the model has {len(X)}")
    bad = np.flatnonzero(~np.all(np.isfinite(X), axis=1))
    if bad.size:
        raise PoseError(f"model points {bad.tolist()[:10]} are not finite")
    return X


def flatness(points: np.ndarray, weights: np.ndarray | None = None) -> float:
    """Thickness over extent of a point cloud: smallest / largest singular value.

    0 for coplanar points; POSIT needs points that are not coplanar.

    Parameters
    ----------
    points : (N, 3) array
    weights : (N,) array, optional
        Non-negative point weights.
    """
    X = np.asarray(points, dtype=np.float64)
    w = np.ones(len(X)) if weights is None else np.asarray(weights, np.float64)
    centre = (w @ X) / w.sum()
    sv = np.linalg.svd((X - centre) * np.sqrt(w)[:, None], compute_uv=False)
    return float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0


def _coplanar_error(ratio: float, limit: float, what: str) -> PoseError:
    return PoseError(
        f"{what} are coplanar or nearly so (thickness/extent {ratio:.3g} < {limit:g}): POSIT "
        "needs non-coplanar points; for a planar target use aamcore.pose.plane_pose"
    )


class Posit:
    """POSIT for one rigid model; call :meth:`estimate` once per frame.

    Parameters
    ----------
    model_points : (N, 3) array
        Model points, N >= 4, not coplanar, in any length unit (the
        translation comes out in that unit).
    tolerance : float
        Stop when no perspective factor ``w_i`` changes by more than this
        (1e-5 moves a point of a 200 px face by about 0.001 px).
    max_iterations : int
        Give up (result flagged unreliable) after this many POSIT iterations.
    refine_iterations : int
        Gauss-Newton steps on the reprojection error after POSIT; 0 for plain
        POSIT as in the thesis. One step reaches the minimum to within the
        bench's precision (``bench/bench_posit.py``).
    max_relative_residual : float
        Flag the estimate unreliable when the RMS reprojection error exceeds
        this fraction of the RMS spread of the image points about their mean.
        Hand-annotated faces against the mean models here reach 0.18 (LFPW,
        805 faces, 99th percentile 0.16) and 0.11 (IMM); points that do not
        belong to the model reach about 1.
    min_flatness : float
        Refuse point sets whose :func:`flatness` is below this.
    max_view_angle_deg : float, optional
        For a model whose front is its -z axis (a face in OpenCV axes): flag
        the estimate unreliable when that axis turns more than this from the
        line of sight to the camera. A face seen from behind is the mirror
        answer POSIT can give for left-right swapped landmarks.

    Raises
    ------
    PoseError
        If the model has fewer than 4 points, non-finite values or coplanar points.
    """

    def __init__(
        self,
        model_points: np.ndarray,
        *,
        tolerance: float = 1e-5,
        max_iterations: int = 100,
        refine_iterations: int = 1,
        max_relative_residual: float = 0.25,
        min_flatness: float = 0.02,
        max_view_angle_deg: float | None = None,
    ) -> None:
        X = _as_model(model_points)
        ratio = flatness(X)
        if ratio < min_flatness:
            raise _coplanar_error(ratio, min_flatness, "the model points")
        self.model_points = X
        self.tolerance = float(tolerance)
        self.max_iterations = int(max_iterations)
        self.refine_iterations = int(refine_iterations)
        self.max_relative_residual = float(max_relative_residual)
        self.min_flatness = float(min_flatness)
        self.max_view_angle_deg = max_view_angle_deg
        # Centring the model keeps M well conditioned; T is moved back to the
        # model's own origin at the end.
        self._centre = X.mean(axis=0)
        self._Xc = X - self._centre
        M = np.hstack([self._Xc, np.ones((len(X), 1))])
        self._M = M
        self._M_pinv = np.linalg.pinv(M)
        self._radius = float(np.sqrt(np.max(np.sum(self._Xc**2, axis=1))))

    @property
    def n_points(self) -> int:
        """Number of model points."""
        return len(self.model_points)

    def estimate(
        self,
        image_points: np.ndarray,
        camera: CameraIntrinsics | np.ndarray,
        weights: np.ndarray | None = None,
    ) -> PoseEstimate:
        """Estimate the model pose from its image.

        Parameters
        ----------
        image_points : (N, 2) array
            Pixel positions of the model points, same order as the model.
        camera : CameraIntrinsics or (3, 3) array
            Intrinsics; points are undistorted first when they include
            distortion. A bare ``K`` means no distortion.
        weights : (N,) array, optional
            Non-negative confidence of each point (0 drops a point).

        Returns
        -------
        PoseEstimate
            Flagged unreliable, with the reason, when POSIT does not converge,
            the model lands behind the camera or the points do not fit it.

        Raises
        ------
        PoseError
            For a wrong shape, non-finite points or weights, fewer than four
            weighted points, or weighted points that are coplanar.
        """
        pts = self._check_points(image_points)
        cam = camera if isinstance(camera, CameraIntrinsics) else CameraIntrinsics(camera)
        return self.estimate_normalised(cam.normalize(pts), np.array(cam.focal), weights)

    def estimate_normalised(self, xy: np.ndarray, fxy: np.ndarray,
                            weights: np.ndarray | None = None) -> PoseEstimate:
        """:meth:`estimate` from finite, undistorted normalised coordinates ``xy`` (N, 2)
        (``K^-1 [u, v, 1]``; not checked) and the focal lengths ``fxy`` (2,), in pixels.

        Raises
        ------
        PoseError
            For weights :meth:`estimate` refuses.
        """
        if weights is None:
            pinv, w_pts = self._M_pinv, None
        else:
            w_pts = self._check_weights(weights)
            Mw = self._M * w_pts[:, None]
            pinv = np.linalg.solve(self._M.T @ Mw, Mw.T)
        R, Tc, iterations, converged, delta = self._posit(xy, pinv)
        if self.refine_iterations > 0 and converged:
            R, Tc = gauss_newton(R, Tc, self._Xc, xy, w_pts, fxy, self.refine_iterations)
        rms, spread, min_depth = self._residual(R, Tc, xy, w_pts, fxy)
        reason = self._problem(converged, iterations, delta, rms, spread, min_depth)
        T = Tc - R @ self._centre
        if not reason and self.max_view_angle_deg is not None:
            reason = _facing_problem(R, T, self.max_view_angle_deg)
        return PoseEstimate(R, T, iterations, converged, reason == "", reason or "ok", rms)

    def _check_points(self, image_points: np.ndarray) -> np.ndarray:
        pts = np.asarray(image_points, dtype=np.float64)
        if pts.shape != (self.n_points, 2):
            raise PoseError(f"image points must have shape ({self.n_points}, 2) to match the "
                            f"model, got {pts.shape}")
        bad = np.flatnonzero(~np.all(np.isfinite(pts), axis=1))
        if bad.size:
            raise PoseError(f"image points {bad.tolist()[:10]} are not finite (NaN or inf)")
        return pts

    def _check_weights(self, weights: np.ndarray) -> np.ndarray:
        w = np.asarray(weights, dtype=np.float64).ravel()
        if w.shape != (self.n_points,):
            raise PoseError(f"weights must have shape ({self.n_points},), got {w.shape}")
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            raise PoseError("weights must be finite and non-negative")
        used = int(np.count_nonzero(w))
        if used < MIN_POINTS:
            raise PoseError(f"only {used} points have non-zero weight; POSIT needs {MIN_POINTS}")
        ratio = flatness(self.model_points, w)
        if ratio < self.min_flatness:
            raise _coplanar_error(ratio, self.min_flatness, "the weighted model points")
        return w

    def _posit(
        self, xy: np.ndarray, pinv: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, int, bool, float]:
        """Algorithm 9 on normalised coordinates; returns R, T (centred), its, converged, dw.

        ``pinv @ (w * [u v])`` is computed as one product ``[pinv*u; pinv*v] @ w``,
        and the 3-vector algebra runs on Python floats: both only for speed.
        """
        Xc = self._Xc
        A = np.vstack([pinv * xy[:, 0], pinv * xy[:, 1]])  # (8, N)
        w = np.ones(len(xy))
        radius = self._radius
        converged = False
        delta = np.inf
        iterations = 0
        rows = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        k = (0.0, 0.0, 0.0)  # r3 / Tz
        tx = ty = 0.0
        s = 1.0
        for iterations in range(1, self.max_iterations + 1):  # noqa: B007
            i0, i1, i2, tx, j0, j1, j2, ty = (A @ w).tolist()
            n_i = sqrt(i0 * i0 + i1 * i1 + i2 * i2)
            n_j = sqrt(j0 * j0 + j1 * j1 + j2 * j2)
            if not (n_i > 0.0 and n_j > 0.0):
                break
            a0, a1, a2 = i0 / n_i, i1 / n_i, i2 / n_i
            b0, b1, b2 = j0 / n_j, j1 / n_j, j2 / n_j
            c0, c1, c2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
            n_c = sqrt(c0 * c0 + c1 * c1 + c2 * c2)
            if not n_c > 0.0:
                break
            s = sqrt(n_i * n_j)  # 1 / Tz
            c0, c1, c2 = c0 / n_c, c1 / n_c, c2 / n_c
            rows = (a0, a1, a2, b0, b1, b2, c0, c1, c2)
            k_new = (c0 * s, c1 * s, c2 * s)
            # |w_i change| <= |P_i| |change of r3/Tz|: a bound that needs no pass over N.
            delta = radius * sqrt(sum((p - q) ** 2 for p, q in zip(k_new, k, strict=True)))
            k = k_new
            w = Xc @ np.array(k)
            w += 1.0
            if delta < self.tolerance:
                converged = True
                break
        R = nearest_rotation(np.array(rows).reshape(3, 3))
        T = np.array([tx / s, ty / s, 1.0 / s])
        return R, T, iterations, converged and isfinite(delta), delta

    def _residual(
        self, R: np.ndarray, Tc: np.ndarray, xy: np.ndarray, w: np.ndarray | None, fxy: np.ndarray
    ) -> tuple[float, float, float]:
        """RMS reprojection error (px), RMS spread of the points (px), smallest depth."""
        P = self._Xc @ R.T + Tc
        z = P[:, 2]
        min_depth = float(z.min())
        if min_depth <= 0:
            return float("inf"), 1.0, min_depth
        err2 = np.sum(((P[:, :2] / z[:, None] - xy) * fxy) ** 2, axis=1)
        spread2 = np.sum(((xy - xy.mean(axis=0)) * fxy) ** 2, axis=1)
        if w is None:
            return float(np.sqrt(err2.mean())), float(np.sqrt(spread2.mean())), min_depth
        ws = w.sum()
        centre = (w @ xy) / ws
        spread2 = np.sum(((xy - centre) * fxy) ** 2, axis=1)
        return float(np.sqrt(w @ err2 / ws)), float(np.sqrt(w @ spread2 / ws)), min_depth

    def _problem(
        self, converged: bool, iterations: int, delta: float, rms: float, spread: float,
        min_depth: float,
    ) -> str:
        if not converged:
            return (f"POSIT did not converge in {iterations} iterations (last change of w "
                    f"{delta:.3g} > tolerance {self.tolerance:g})")
        if min_depth <= 0:
            return "part of the model lands behind the camera"
        if rms > self.max_relative_residual * spread:
            return (f"reprojection error {rms:.2f} px is {rms / spread:.0%} of the point spread "
                    f"{spread:.1f} px (limit {self.max_relative_residual:.0%}): the points do "
                    "not fit the model")
        return ""


def _facing_problem(R: np.ndarray, T: np.ndarray, limit_deg: float) -> str:
    """Why the model's front (-z) does not face the camera, or an empty string."""
    cos = float(R[:, 2] @ T) / float(np.sqrt(T @ T))
    angle = float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    if angle > limit_deg:
        return (f"the model faces away from the camera ({angle:.0f} deg from the line of sight, "
                f"limit {limit_deg:g}): left and right landmarks swapped?")
    return ""
