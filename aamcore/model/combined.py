"""Combined appearance model (thesis chapter 5): ``b = Phi_c c``.

``b = (W_s b_s, b_g)`` with ``W_s = r I``; the appearance vector ``c``
controls shape and texture together (eqs. 5.1-5.6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.model.pca import PCA, fit_pca


def shape_weight(shape_variances: np.ndarray, texture_variances: np.ndarray) -> float:
    """The weight ``r`` of ``W_s = r I`` (eqs. 5.7, 5.8).

    ``r^2`` is the ratio of total texture variance to total shape variance, as
    in Cootes' formulation; the thesis's eq. 5.8 writes the ratio itself, which
    would give ``r`` units of intensity squared per distance squared rather
    than intensity per distance.
    """
    return float(np.sqrt(texture_variances.sum() / shape_variances.sum()))


@dataclass(frozen=True)
class CombinedModel:
    """PCA of concatenated, weighted shape and texture parameters.

    Attributes
    ----------
    pca : PCA
        Over ``(r b_s, b_g)``; its mean is zero by construction.
    weight : float
        ``r``.
    n_shape : int
        Number of shape parameters ``t_s``.
    """

    pca: PCA
    weight: float
    n_shape: int

    @classmethod
    def train(
        cls,
        b_s: np.ndarray,
        b_g: np.ndarray,
        shape_variances: np.ndarray,
        texture_variances: np.ndarray,
        variance: float,
    ) -> CombinedModel:
        """Fit the third PCA on parameters ``b_s`` (S, t_s) and ``b_g`` (S, t_g)."""
        weight = shape_weight(shape_variances, texture_variances)
        data = np.hstack([weight * b_s, b_g])
        pca = fit_pca(data, variance)
        # b_s and b_g have zero mean over the training set; keep the model's
        # mean exactly zero so that c = 0 is the mean face.
        pca = PCA(np.zeros_like(pca.mean), pca.components, pca.variances, pca.total_variance)
        return cls(pca, weight, b_s.shape[1])

    @property
    def n_modes(self) -> int:
        return self.pca.n_modes

    @property
    def shape_block(self) -> np.ndarray:
        """``W_s^-1 Phi_cs``, (t_s, t_c): ``b_s = shape_block @ c`` (eq. 5.3)."""
        return self.pca.components[: self.n_shape] / self.weight

    @property
    def texture_block(self) -> np.ndarray:
        """``Phi_cg``, (t_g, t_c): ``b_g = texture_block @ c`` (eq. 5.4)."""
        return self.pca.components[self.n_shape :]

    def split(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Shape and texture parameters ``(b_s, b_g)`` of appearance ``c``."""
        return self.shape_block @ c, self.texture_block @ c

    def params(self, b_s: np.ndarray, b_g: np.ndarray) -> np.ndarray:
        """Appearance ``c`` of ``(b_s, b_g)`` (eq. 5.6)."""
        return self.pca.project(np.concatenate([self.weight * b_s, b_g]))

    def limits(self, n_sigma: float = 3.0) -> np.ndarray:
        """``n_sigma sqrt(lambda_c)``: the failure test of eq. 7.2 uses 3."""
        return self.pca.limits(n_sigma)
