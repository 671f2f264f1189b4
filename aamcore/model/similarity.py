"""The 2D similarity transform, the one type for every placement of a shape in an image.

A :class:`Similarity` maps ``x -> s R(theta) x + t``. It is held in the linear
form ``a = s cos(theta)``, ``b = s sin(theta)`` so that applying and composing
it need no trigonometry. The AAM's pose parameters (thesis eqs. 6.3, 6.4) are
``params = (a - 1, b, t_x, t_y)``: zero is the identity and a shape is linear
in them, which is what the update matrices of chapter 6 rely on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def centroid(points: np.ndarray) -> np.ndarray:
    """The mean (2,) of ``points`` (N, 2): :func:`numpy.mean`'s arithmetic (a sum, then a
    division by the count), without its overhead (a few microseconds a call, a dozen calls a
    tracked frame)."""
    return np.add.reduce(points, axis=0) / len(points)


@dataclass(frozen=True)
class Similarity:
    """A 2D similarity ``x -> [[a, -b], [b, a]] x + (tx, ty)``.

    Attributes
    ----------
    a, b : float
        ``scale * cos(angle)`` and ``scale * sin(angle)``.
    tx, ty : float
        The translation.
    """

    a: float = 1.0
    b: float = 0.0
    tx: float = 0.0
    ty: float = 0.0

    @classmethod
    def from_scale_angle(
        cls, scale: float, angle: float, translation: np.ndarray | tuple[float, float] = (0, 0)
    ) -> Similarity:
        """The similarity of a scale, an angle (radians, counter-clockwise) and a translation."""
        tx, ty = (float(v) for v in translation)
        return cls(scale * math.cos(angle), scale * math.sin(angle), tx, ty)

    @classmethod
    def from_estimate(cls, src: np.ndarray, dst: np.ndarray) -> Similarity:
        """The least-squares similarity mapping ``src`` (N, 2) onto ``dst`` (N, 2).

        In 2D the optimum has a closed form (thesis eqs. 3.9, 3.10): with both
        shapes centred, ``a = sum(x x' + y y') / |x|^2`` and
        ``b = sum(x y' - y x') / |x|^2``; it is Algorithm 1's transform without the SVD.

        Raises
        ------
        ValueError
            For shapes of different sizes or a source whose points all coincide.
        """
        src, dst = np.asarray(src, np.float64), np.asarray(dst, np.float64)
        if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 2:
            raise ValueError(f"need two (N, 2) arrays of equal shape, got {src.shape} and "
                             f"{dst.shape}")
        mu_s, mu_t = src.mean(axis=0), dst.mean(axis=0)
        s_c, t_c = src - mu_s, dst - mu_t
        denom = float(np.sum(s_c * s_c))
        if denom == 0:
            raise ValueError("degenerate source shape: all points coincide")
        a = float(np.sum(s_c * t_c)) / denom
        b = float(np.sum(s_c[:, 0] * t_c[:, 1] - s_c[:, 1] * t_c[:, 0])) / denom
        return cls(a, b, float(mu_t[0] - a * mu_s[0] + b * mu_s[1]),
                   float(mu_t[1] - b * mu_s[0] - a * mu_s[1]))

    @classmethod
    def from_params(cls, t: np.ndarray) -> Similarity:
        """The similarity of AAM pose parameters ``t = (a - 1, b, tx, ty)`` (4,)."""
        return cls(1.0 + float(t[0]), float(t[1]), float(t[2]), float(t[3]))

    @property
    def params(self) -> np.ndarray:
        """AAM pose parameters ``(a - 1, b, tx, ty)`` (4,)."""
        return np.array([self.a - 1.0, self.b, self.tx, self.ty])

    @property
    def scale(self) -> float:
        return math.hypot(self.a, self.b)

    @property
    def angle(self) -> float:
        """Rotation in radians, counter-clockwise in ``(x, y)`` coordinates."""
        return math.atan2(self.b, self.a)

    @property
    def translation(self) -> np.ndarray:
        return np.array([self.tx, self.ty])

    @property
    def linear(self) -> np.ndarray:
        """The 2x2 matrix ``scale * R(angle)``."""
        return np.array([[self.a, -self.b], [self.b, self.a]])

    @property
    def matrix(self) -> np.ndarray:
        """The 2x3 matrix ``[linear | translation]``."""
        return np.array([[self.a, -self.b, self.tx], [self.b, self.a, self.ty]])

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transform ``points`` (N, 2); returns (N, 2) float64."""
        points = np.asarray(points, dtype=np.float64)
        x, y = points[..., 0], points[..., 1]
        return np.stack([self.a * x - self.b * y + self.tx, self.b * x + self.a * y + self.ty], -1)

    def inverse(self) -> Similarity:
        """The inverse transform."""
        d = self.a * self.a + self.b * self.b
        if d == 0:
            raise ValueError("a similarity of scale 0 has no inverse")
        a, b = self.a / d, -self.b / d
        return Similarity(a, b, -(a * self.tx - b * self.ty), -(b * self.tx + a * self.ty))

    def __matmul__(self, inner: Similarity) -> Similarity:
        """``self @ inner``: the transform ``x -> self(inner(x))``."""
        a = self.a * inner.a - self.b * inner.b
        b = self.b * inner.a + self.a * inner.b
        tx = self.a * inner.tx - self.b * inner.ty + self.tx
        ty = self.b * inner.tx + self.a * inner.ty + self.ty
        return Similarity(a, b, tx, ty)

    def scaled(self, factor: float) -> Similarity:
        """The same placement in an image scaled by ``factor`` about the origin."""
        return Similarity(self.a * factor, self.b * factor, self.tx * factor, self.ty * factor)


def apply_pose(t: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (N, 2) placed by pose parameters ``t`` (4,): ``Similarity.from_params(t)``."""
    return Similarity.from_params(t).apply(points)


class Placement:
    """Least-squares placements of one reference shape onto many shapes, batched.

    The linear part of :meth:`Similarity.from_estimate` with a fixed source: its matrix
    (2N, 2) is computed once, so that the cascades place the mean shape on thousands of
    shapes a second.

    Parameters
    ----------
    reference : (N, 2) array
        The shape placed (its centroid is taken out).
    """

    def __init__(self, reference: np.ndarray) -> None:
        reference = np.asarray(reference, np.float64)
        self.reference = reference
        self.centroid = reference.mean(axis=0)
        m = reference - self.centroid
        norm = float(np.sum(m * m))
        if norm == 0:
            raise ValueError("degenerate reference shape: all points coincide")
        self.matrix = (np.stack([m.ravel(), np.stack([-m[:, 1], m[:, 0]], 1).ravel()])
                       / norm).T
        """(2N, 2): a shape's flattened points times it are the ``(a, b)`` placing the
        reference on the shape."""

    def ab(self, shapes: np.ndarray) -> np.ndarray:
        """``(a, b)`` (..., 2) of the reference placed on each of ``shapes`` (..., N, 2)."""
        shapes = np.asarray(shapes, np.float64)
        return shapes.reshape(*shapes.shape[:-2], -1) @ self.matrix

    def onto(self, points: np.ndarray) -> Similarity:
        """The least-squares similarity placing the reference on ``points`` (N, 2)."""
        a, b = self.ab(points).tolist()
        cx, cy = (centroid(np.asarray(points, np.float64))
                  - np.array([[a, -b], [b, a]]) @ self.centroid).tolist()
        return Similarity(a, b, cx, cy)
