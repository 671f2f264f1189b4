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
