"""Rotation matrices and roll-pitch-yaw angles (thesis eqs 14.1-14.3).

The thesis writes the head orientation as ``R = Rz(alpha) Ry(beta) Rx(gamma)``
(eq 14.1) and inverts it with eq 14.3. This module keeps that Z-Y-X order
and those formulas, and names the angles by the axes of the OpenCV camera and
head frames used throughout the package (+x right, +y down, +z away from the
camera; the face looks at the camera when ``R`` is the identity):

- **roll** about z (head tilt); positive turns the face clockwise in the image;
- **yaw** about y (head turn); positive moves the nose towards image left,
  i.e. the subject turns to their right;
- **pitch** about x (nod); positive moves the nose down.

So ``R = Rz(roll) @ Ry(yaw) @ Rx(pitch)``. (The thesis's labels for the y and
x rotations follow its own model axes; with OpenCV axes the rotation about the
vertical axis is the yaw.)
"""

from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import numpy as np


class RPY(NamedTuple):
    """Roll, pitch and yaw of a head rotation, in degrees unless said otherwise."""

    roll: float
    pitch: float
    yaw: float


def rot_x(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about the x axis, shape (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about the y axis, shape (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about the z axis, shape (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_from_rpy(roll: float, pitch: float, yaw: float, degrees: bool = True) -> np.ndarray:
    """Build ``Rz(roll) @ Ry(yaw) @ Rx(pitch)`` (eq 14.1), shape (3, 3)."""
    angles = np.radians([roll, pitch, yaw]) if degrees else np.array([roll, pitch, yaw], float)
    return rot_z(angles[0]) @ rot_y(angles[2]) @ rot_x(angles[1])


def rpy_from_rotation(R: np.ndarray, degrees: bool = True) -> RPY:
    """Roll, pitch and yaw of a rotation matrix (eq 14.3).

    Parameters
    ----------
    R : (3, 3) array
        A rotation matrix.
    degrees : bool
        Return degrees (default) or radians.

    Returns
    -------
    RPY
        Angles with ``R == rotation_from_rpy(*angles)``; yaw lies in
        [-90, 90] degrees, roll and pitch in (-180, 180].

    Raises
    ------
    ValueError
        If ``R`` is not a finite (3, 3) array.
    """
    R = np.asarray(R, dtype=np.float64)
    if R.shape != (3, 3) or not np.isfinite(R).all():
        raise ValueError(f"rotation must be a finite (3, 3) array, got shape {R.shape}")
    (r00, _, _), (r10, _, _), (r20, r21, r22) = R.tolist()
    roll = math.atan2(r10, r00)
    yaw = math.atan2(-r20, r00 * math.cos(roll) + r10 * math.sin(roll))
    pitch = math.atan2(r21, r22)
    if degrees:
        return RPY(math.degrees(roll), math.degrees(pitch), math.degrees(yaw))
    return RPY(roll, pitch, yaw)


def nearest_rotation(M: np.ndarray) -> np.ndarray:
    """The rotation matrix closest to ``M`` in the Frobenius norm, shape (3, 3).

    Parameters
    ----------
    M : (3, 3) array
        A matrix near a rotation, e.g. POSIT's rows ``r1, r2, r3`` that are only
        approximately orthonormal.
    """
    _, u, vt = cv2.SVDecomp(np.asarray(M, dtype=np.float64))
    R = u @ vt
    (a, b, c), (d, e, f), (g, h, i) = R.tolist()
    if a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) < 0.0:
        # a reflection: turn the least stretched axis back
        R = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    return R


def rotation_angle_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Angle in degrees of the rotation taking ``R_b`` to ``R_a`` (geodesic distance)."""
    cos = (np.trace(R_a @ R_b.T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
