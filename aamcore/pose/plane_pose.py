"""Pose of a plane from its homography (thesis appendix A).

For a plane ``Z = 0`` in its own frame, the homography from plane to image is
``H ~ K [R1 R2 T]`` (eq A.1). With ``W = K^-1 H`` and ``l = sqrt(|W1| |W2|)``
(eqs A.2, A.3), ``R1, R2, T = W1/l, W2/l, W3/l``; the two columns are made
orthonormal symmetrically (eqs A.4, A.5) and ``R3 = R1' x R2'`` (eq A.6).
"""

from __future__ import annotations

import cv2
import numpy as np

from aamcore.pose.errors import PoseError
from aamcore.pose.intrinsics import CameraIntrinsics
from aamcore.pose.posit import PoseEstimate


def pose_from_homography(H: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation of a plane from its plane-to-image homography.

    Parameters
    ----------
    H : (3, 3) array
        Homography from plane coordinates ``(X, Y, 1)`` to pixels, any scale.
    K : (3, 3) array
        Camera matrix.

    Returns
    -------
    R : (3, 3) array
        Plane-to-camera rotation; its third column is the plane normal.
    T : (3,) array
        Plane origin in the camera frame, in the plane coordinates' unit, in
        front of the camera (``T[2] > 0``).

    Raises
    ------
    PoseError
        If ``H`` is not finite or is degenerate (rank below 3).
    """
    H = np.asarray(H, dtype=np.float64)
    if H.shape != (3, 3) or not np.all(np.isfinite(H)):
        raise PoseError(f"homography must be a finite (3, 3) array, got shape {H.shape}")
    W = np.linalg.solve(np.asarray(K, dtype=np.float64), H)
    n1, n2 = np.linalg.norm(W[:, 0]), np.linalg.norm(W[:, 1])
    if n1 == 0.0 or n2 == 0.0 or abs(np.linalg.det(W)) < 1e-12 * (n1 * n2) ** 1.5:
        raise PoseError("degenerate homography: the plane is seen edge-on or H is singular")
    W = W / np.sqrt(n1 * n2)
    if W[2, 2] < 0:  # H has an arbitrary sign: put the plane in front of the camera
        W = -W
    r1, r2, T = W[:, 0], W[:, 1], W[:, 2]
    c = r1 + r2
    p = np.cross(r1, r2)
    d = np.cross(c, p)
    c, d = c / np.linalg.norm(c), d / np.linalg.norm(d)
    r1n = (c + d) / np.sqrt(2.0)
    r2n = (c - d) / np.sqrt(2.0)
    R = np.column_stack([r1n, r2n, np.cross(r1n, r2n)])
    return R, T.copy()


def plane_pose(
    plane_points: np.ndarray,
    image_points: np.ndarray,
    camera: CameraIntrinsics,
    max_rms_px: float = 2.0,
) -> PoseEstimate:
    """Pose of a planar target (e.g. a checkerboard) from point correspondences.

    The homography is fitted (least squares, ``cv2.findHomography``) between
    the plane points and the undistorted normalised image points, so that
    ``K`` is the identity in :func:`pose_from_homography`.

    Parameters
    ----------
    plane_points : (N, 2) array
        Points in the plane's frame (e.g. mm on the board), N >= 4.
    image_points : (N, 2) array
        Their pixel positions.
    camera : CameraIntrinsics
    max_rms_px : float
        Flag the result unreliable above this RMS reprojection error.

    Returns
    -------
    PoseEstimate
        ``R``, ``T`` of the plane frame (``iterations`` is 0: no iteration).

    Raises
    ------
    PoseError
        For mismatched or too few points, non-finite values, or points that
        give no homography (e.g. collinear).
    """
    obj = np.asarray(plane_points, dtype=np.float64)
    img = np.asarray(image_points, dtype=np.float64)
    if obj.ndim != 2 or obj.shape[1] != 2 or img.shape != obj.shape:
        raise PoseError(f"need (N, 2) plane and image points of equal shape, got {obj.shape} "
                        f"and {img.shape}")
    if len(obj) < 4:
        raise PoseError(f"a homography needs at least 4 points, got {len(obj)}")
    if not (np.all(np.isfinite(obj)) and np.all(np.isfinite(img))):
        raise PoseError("plane or image points are not finite")
    xy = camera.normalize(img)
    H, _ = cv2.findHomography(obj, xy, 0)
    if H is None:
        raise PoseError("no homography fits these points (collinear or repeated points?)")
    R, T = pose_from_homography(H, np.eye(3))
    cam_pts = np.column_stack([obj, np.zeros(len(obj))]) @ R.T + T
    proj = camera.project(np.column_stack([obj, np.zeros(len(obj))]), R, T)
    rms = float(np.sqrt(np.mean(np.sum((proj - img) ** 2, axis=1))))
    if np.any(cam_pts[:, 2] <= 0):
        reason = "part of the plane lands behind the camera"
    elif rms > max_rms_px:
        reason = f"reprojection error {rms:.2f} px exceeds {max_rms_px:g} px"
    else:
        reason = ""
    return PoseEstimate(R, T, 0, True, reason == "", reason or "ok", rms)
