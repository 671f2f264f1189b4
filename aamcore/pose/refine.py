"""Gauss-Newton refinement of a pose on the pixel reprojection error.

:class:`~aamcore.pose.posit.Posit` seeds it with the POSIT pose: POSIT solves
for ``r1`` and ``r2`` independently, which makes it noisier than the
maximum-likelihood estimate these steps reach.
"""

from __future__ import annotations

import numpy as np


def _skew_exp(omega: np.ndarray) -> np.ndarray:
    """Rotation matrix of the rotation vector ``omega`` (Rodrigues), shape (3, 3)."""
    theta = np.sqrt(omega @ omega)
    if theta < 1e-12:
        return np.eye(3)
    k = omega / theta
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(theta) * K + (1.0 - np.cos(theta)) * (K @ K)


def _linearise(
    R: np.ndarray,
    T: np.ndarray,
    X: np.ndarray,
    xy: np.ndarray,
    su: np.ndarray,
    sv: np.ndarray,
    J: np.ndarray,
) -> np.ndarray | None:
    """Weighted pixel residuals at ``(R, T)``, filling their Jacobian into ``J``.

    Parameters
    ----------
    R, T : (3, 3) and (3,) arrays
        The pose of the centred model ``X``.
    X : (N, 3) array
    xy : (N, 2) array
        Normalised image coordinates.
    su, sv : (N,) arrays
        Square-root point weights times the focal lengths ``fx`` and ``fy``.
    J : (2N, 6) array
        Overwritten with ``d r / d (omega, T)``, ``omega`` the left rotation update.

    Returns
    -------
    (2N,) array or None
        Residuals ``u`` then ``v``; None if a point is at or behind the camera.
    """
    n = len(X)
    Q = X @ R.T
    qx, qy, qz = Q[:, 0], Q[:, 1], Q[:, 2]
    z = qz + T[2]
    if z.min() <= 0:
        return None
    iz = 1.0 / z
    u = (qx + T[0]) * iz
    v = (qy + T[1]) * iz
    r = np.concatenate([(u - xy[:, 0]) * su, (v - xy[:, 1]) * sv])
    a, b = iz * su, iz * sv
    J[:n, 0] = -u * qy * a
    J[:n, 1] = (qz + u * qx) * a
    J[:n, 2] = -qy * a
    J[:n, 3] = a
    J[:n, 4] = 0.0
    J[:n, 5] = -u * a
    J[n:, 0] = -(qz + v * qy) * b
    J[n:, 1] = v * qx * b
    J[n:, 2] = qx * b
    J[n:, 3] = 0.0
    J[n:, 4] = b
    J[n:, 5] = -v * b
    return r


def gauss_newton(
    R: np.ndarray,
    T: np.ndarray,
    X: np.ndarray,
    xy: np.ndarray,
    w: np.ndarray | None,
    fxy: np.ndarray,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Minimise the (weighted) pixel reprojection error over ``(R, T)`` from a start pose.

    Left-multiplicative rotation updates ``R <- exp([omega]x) R``. Started from
    POSIT the error is nearly quadratic in the pose, so the steps are taken
    without line search; the start pose is kept if the end pose is worse.

    Parameters
    ----------
    R, T : (3, 3) and (3,) arrays
        Start pose for the centred model ``X``.
    X : (N, 3) array
    xy : (N, 2) array
        Normalised image coordinates.
    w : (N,) array or None
        Point weights.
    fxy : (2,) array
        Focal lengths, to measure the error in pixels.
    iterations : int

    Returns
    -------
    R, T : (3, 3) and (3,) arrays
        The refined pose, or the start pose.
    """
    n = len(X)
    sw = np.ones(n) if w is None else np.sqrt(w)
    su, sv = sw * fxy[0], sw * fxy[1]
    J = np.empty((2 * n, 6))
    R0, T0 = R, T
    cost0 = np.inf
    for _ in range(iterations):
        r = _linearise(R, T, X, xy, su, sv, J)
        if r is None:
            return R0, T0
        if cost0 == np.inf:
            cost0 = r @ r
        try:
            step = np.linalg.solve(J.T @ J, -(J.T @ r))
        except np.linalg.LinAlgError:
            break
        R = _skew_exp(step[:3]) @ R
        T = T + step[3:]
    P = X @ R.T + T
    if P[:, 2].min() <= 0:
        return R0, T0
    e = np.concatenate([(P[:, 0] / P[:, 2] - xy[:, 0]) * su, (P[:, 1] / P[:, 2] - xy[:, 1]) * sv])
    return (R, T) if e @ e <= cost0 else (R0, T0)


def reprojection_rows(
    R: np.ndarray, T: np.ndarray, X: np.ndarray, xy: np.ndarray, fxy: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Pixel residuals of model points against their images, and their Jacobian.

    Parameters
    ----------
    R, T : (3, 3) and (3,) arrays
        Pose of the model; the rotation update is ``R <- exp([omega]x) R``.
    X : (N, 3) array
        Model points.
    xy : (N, 2) array
        Normalised image coordinates.
    fxy : (2,) array
        Focal lengths, to measure residuals in pixels.

    Returns
    -------
    r : (2N,) array
        x residuals of all points, then y residuals.
    J : (2N, 6) array
        Derivatives with respect to ``(omega, T)``.

    None when a point is at or behind the camera.
    """
    n = len(X)
    J = np.empty((2 * n, 6))
    r = _linearise(R, T, X, xy, np.full(n, float(fxy[0])), np.full(n, float(fxy[1])), J)
    return None if r is None else (r, J)
