"""Statistical shape model (thesis section 3.4): ``x = mean + Phi_s b_s``.

Shapes live in the *model frame*: aligned by GPA, centred on the origin and
scaled so that the mean shape covers the texture reference frame. The pose
:class:`~aamcore.model.similarity.Similarity` maps the model frame to an image.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.model.pca import PCA, fit_pca
from aamcore.model.procrustes import generalised_procrustes
from aamcore.model.similarity import Similarity


@dataclass(frozen=True)
class ShapeModel:
    """PCA of aligned shapes.

    Attributes
    ----------
    pca : PCA
        Over flattened shapes ``(x1, y1, x2, y2, ...)`` of length ``2N``.
    """

    pca: PCA

    @classmethod
    def train(cls, shapes: np.ndarray, variance: float, scale: float) -> ShapeModel:
        """GPA-align ``shapes`` (S, N, 2), scale them by ``scale`` and fit a PCA."""
        aligned, _, _ = generalised_procrustes(shapes)
        flat = (aligned * scale).reshape(len(aligned), -1)
        return cls(fit_pca(flat, variance))

    @property
    def n_points(self) -> int:
        return self.pca.mean.size // 2

    @property
    def n_modes(self) -> int:
        return self.pca.n_modes

    @property
    def mean_shape(self) -> np.ndarray:
        """Mean shape in the model frame, (N, 2)."""
        return self.pca.mean.reshape(-1, 2)

    @property
    def components(self) -> np.ndarray:
        """Modes as shapes, (k, N, 2)."""
        return self.pca.components.T.reshape(self.n_modes, -1, 2)

    def instance(self, b: np.ndarray) -> np.ndarray:
        """Model-frame shape (N, 2) for parameters ``b`` (k,) (eq. 3.17)."""
        return self.pca.reconstruct(b).reshape(-1, 2)

    def params(self, shape: np.ndarray) -> np.ndarray:
        """Parameters (k,) of a model-frame shape (N, 2) (eq. 3.18)."""
        return self.pca.project(shape.reshape(-1))

    def clip(self, b: np.ndarray, n_sigma: float = 3.0) -> np.ndarray:
        """``b`` limited to ``+-n_sigma sqrt(lambda)``."""
        lim = self.pca.limits(n_sigma)
        return np.clip(b, -lim, lim)

    def fit_points(self, points: np.ndarray, iterations: int = 3) -> tuple[np.ndarray, Similarity]:
        """Shape parameters and placement that best explain image ``points`` (N, 2).

        Returns
        -------
        b : (k,) array
        similarity : Similarity
            Maps the model frame onto the image.
        """
        b = np.zeros(self.n_modes)
        sim = Similarity()
        for _ in range(iterations):
            sim = Similarity.from_estimate(self.instance(b), points)
            b = self.params(sim.inverse().apply(points))
        return b, sim
