"""The shape space a cascaded regression steps in: similarity directions and shape modes.

Every step of the local-binary cascade (:mod:`aamcore.fitting.algorithm.local_binary`)
is a vector in the orthonormal basis of the 4 similarity directions of the mean
shape and the shape modes, and its result is projected back onto the shape model
with the parameters limited to 3 sd: the shape model is the regulariser.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.model.shape import ShapeModel
from aamcore.model.similarity import Placement


def similarity_basis(mean: np.ndarray) -> np.ndarray:
    """The 4 similarity directions (2N, 4) of a centred ``mean`` shape (N, 2):
    scale, rotation, x and y shift."""
    x, y = mean[:, 0], mean[:, 1]
    n = len(mean)
    return np.stack([mean.ravel(), np.stack([-y, x], 1).ravel(),
                     np.tile([1.0, 0.0], n), np.tile([0.0, 1.0], n)], axis=1)


@dataclass(frozen=True)
class ShapeSpace:
    """A shape model as the cascade uses it.

    Attributes
    ----------
    mean : (N, 2) float64 array
        Mean shape in the model frame, centred on the origin.
    modes : (2N, k) float64 array
        Orthonormal shape modes (PCA components).
    limits : (k,) float64 array
        Largest magnitude of each mode's parameter (3 sd).
    basis : (2N, Q) float64 array
        Orthonormal basis of the steps: the similarity directions of the mean
        shape, then the modes (``Q = 4 + k``).
    eye_corners : (int, int)
        The outer eye corners of the markup (iBUG-68: 36 and 45).
    """

    mean: np.ndarray
    modes: np.ndarray
    limits: np.ndarray
    basis: np.ndarray
    eye_corners: tuple[int, int] = (36, 45)

    @classmethod
    def from_model(cls, mean: np.ndarray, modes: np.ndarray, limits: np.ndarray,
                   eye_corners: tuple[int, int] = (36, 45)) -> ShapeSpace:
        """Shape space of a ``mean`` (N, 2), ``modes`` (2N, k) and ``limits`` (k,)."""
        mean = np.asarray(mean, dtype=np.float64)
        mean = mean - mean.mean(axis=0)
        modes = np.asarray(modes, np.float64)
        basis, _ = np.linalg.qr(np.hstack([similarity_basis(mean), modes]))
        return cls(mean, modes, np.asarray(limits, np.float64), basis, eye_corners)

    @classmethod
    def train(cls, shapes: np.ndarray, variance: float, eye_corners: tuple[int, int] = (36, 45)
              ) -> ShapeSpace:
        """The shape space of training ``shapes`` (S, N, 2) keeping ``variance`` of their
        variation (Procrustes-aligned PCA)."""
        model = ShapeModel.train(np.asarray(shapes, np.float64), variance, 100.0)
        return cls.from_model(model.mean_shape, model.pca.components, model.pca.limits(3.0),
                              eye_corners)

    def __post_init__(self) -> None:
        if not all(0 <= k < self.n_points for k in self.eye_corners):
            raise ValueError(f"eye corners {self.eye_corners} of a {self.n_points}-point shape")
        object.__setattr__(self, "_placement", Placement(self.mean))

    @property
    def n_points(self) -> int:
        return len(self.mean)

    @property
    def eye_distance(self) -> float:
        """Outer-eye-corner distance of the mean shape: the unit of the stages' radii."""
        a, b = self.eye_corners
        return float(np.linalg.norm(self.mean[a] - self.mean[b]))

    def similarity(self, shapes: np.ndarray) -> np.ndarray:
        """Least-squares ``(a, b)`` (..., 2) with ``shape ~ mean @ [[a, b], [-b, a]] + centroid``
        for ``shapes`` (..., N, 2): ``a = s cos(theta)``, ``b = s sin(theta)``."""
        return self._placement.ab(shapes)

    def project(self, shapes: np.ndarray) -> np.ndarray:
        """The nearest shapes (S, N, 2) of the model, parameters limited, to image shapes
        (S, N, 2)."""
        ab = self.similarity(shapes)
        centre = shapes.mean(axis=-2, keepdims=True)
        a, b = ab[..., 0, None, None], ab[..., 1, None, None]
        rel = shapes - centre
        scale2 = a * a + b * b
        # the inverse of x -> x @ [[a, b], [-b, a]] is x -> x @ [[a, -b], [b, a]] / s^2
        mx = (rel[..., 0:1] * a + rel[..., 1:2] * b) / scale2
        my = (-rel[..., 0:1] * b + rel[..., 1:2] * a) / scale2
        model = np.concatenate([mx, my], axis=-1) - self.mean
        params = model.reshape(*model.shape[:-2], -1) @ self.modes
        params = np.clip(params, -self.limits, self.limits)
        fitted = self.mean + (params @ self.modes.T).reshape(model.shape)
        x = fitted[..., 0:1] * a - fitted[..., 1:2] * b
        y = fitted[..., 0:1] * b + fitted[..., 1:2] * a
        return np.concatenate([x, y], axis=-1) + centre

    def to_model_frame(self, shapes: np.ndarray, moves: np.ndarray) -> np.ndarray:
        """Image-frame ``moves`` (S, N, 2) of ``shapes`` (S, N, 2) in each shape's model frame."""
        ab = self.similarity(shapes)
        a, b = ab[:, 0, None], ab[:, 1, None]
        s2 = a * a + b * b
        x = (moves[..., 0] * a + moves[..., 1] * b) / s2
        y = (-moves[..., 0] * b + moves[..., 1] * a) / s2
        return np.stack([x, y], axis=-1)

    def step_targets(self, shapes: np.ndarray, truths: np.ndarray) -> np.ndarray:
        """What a stage regresses (S, Q): the moves from ``shapes`` to ``truths`` (S, N, 2)
        in their model frames, in :attr:`basis` coordinates."""
        moves = self.to_model_frame(shapes, truths - shapes)
        return moves.reshape(len(moves), -1) @ self.basis

    def apply_steps(self, shapes: np.ndarray, steps: np.ndarray, project: bool = True
                    ) -> np.ndarray:
        """``shapes`` (S, N, 2) moved by ``steps`` (S, Q) in their model frames, then
        projected onto the model if ``project``."""
        ab = self.similarity(shapes)
        move = (steps @ self.basis.T).reshape(shapes.shape)
        a, b = ab[:, 0, None], ab[:, 1, None]
        image = np.stack([move[..., 0] * a - move[..., 1] * b,
                          move[..., 0] * b + move[..., 1] * a], axis=-1)
        moved = shapes + image
        return self.project(moved) if project else moved

    def arrays(self, prefix: str) -> dict[str, np.ndarray]:
        """The space as named arrays for a model file.

        The basis is stored too: the stages' weights are in its coordinates, and
        another LAPACK could give a QR factor of other signs.
        """
        return {f"{prefix}_mean": self.mean, f"{prefix}_modes": self.modes,
                f"{prefix}_limits": self.limits, f"{prefix}_basis": self.basis,
                f"{prefix}_eye_corners": np.array(self.eye_corners, dtype=np.int64)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str) -> ShapeSpace:
        """The space written by :meth:`arrays`.

        Raises
        ------
        ValueError
            When the arrays do not agree in size.
        """
        mean = np.asarray(arrays[f"{prefix}_mean"], np.float64)
        modes = np.asarray(arrays[f"{prefix}_modes"], np.float64)
        limits = np.asarray(arrays[f"{prefix}_limits"], np.float64)
        basis = np.asarray(arrays[f"{prefix}_basis"], np.float64)
        n, k = mean.size, limits.size
        if mean.shape != (n // 2, 2) or modes.shape != (n, k) or basis.shape != (n, k + 4):
            raise ValueError(f"shape space arrays disagree: mean {mean.shape}, modes "
                             f"{modes.shape}, limits {limits.shape}, basis {basis.shape}")
        a, b = (int(v) for v in arrays[f"{prefix}_eye_corners"])
        return cls(mean, modes, limits, basis, (a, b))
