"""Statistical texture model (thesis chapter 4): ``g = mean + Phi_g b_g``.

Textures are sampled in the reference frame by the piecewise-affine warp,
flattened to vectors of ``M * C`` values and photometrically normalised.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from aamcore.model.pca import PCA, fit_pca


def normalise_texture(g: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Photometric normalisation (eq. 4.8): ``g_norm = (g - beta) / alpha``.

    ``beta`` is the mean and ``alpha`` the standard deviation of ``g``, so the
    result has zero mean and norm ``sqrt(len(g))``: the thesis's unit norm
    times a constant, which keeps values near 1 whatever the frame size.

    Returns
    -------
    g_norm : array like ``g``
    alpha, beta : float
    """
    beta = float(g.mean())
    alpha = float(g.std())
    if alpha < 1e-6:
        alpha = 1.0  # a flat texture: leave it flat rather than divide by zero
    return (g - beta) / alpha, alpha, beta


def equalise_region(image: np.ndarray, points: np.ndarray, margin: float = 0.1) -> np.ndarray:
    """Histogram-equalise each channel inside the bounding box of ``points`` (N, 2).

    The thesis (section 4.3) equalises a rectangular face region per colour
    channel to reduce lighting effects. Returns a new image; the rest of the
    image is unchanged.
    """
    height, width = image.shape[:2]
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = (hi - lo) * margin
    x0, y0 = np.clip(np.floor(lo - pad).astype(int), 0, [width - 1, height - 1])
    x1, y1 = np.clip(np.ceil(hi + pad).astype(int), 0, [width - 1, height - 1])
    out = image.copy()
    if x1 <= x0 or y1 <= y0:
        return out
    region = out[y0 : y1 + 1, x0 : x1 + 1]
    if region.ndim == 2:
        region[:] = cv2.equalizeHist(np.ascontiguousarray(region))
    else:
        for c in range(region.shape[2]):
            region[..., c] = cv2.equalizeHist(np.ascontiguousarray(region[..., c]))
    return out


@dataclass(frozen=True)
class TextureModel:
    """PCA of normalised textures.

    Attributes
    ----------
    pca : PCA
        Over textures flattened to ``M * C`` values (pixel-major).
    channels : int
        1 (grey) or 3 (BGR colour).
    """

    pca: PCA
    channels: int

    @classmethod
    def train(cls, textures: np.ndarray, variance: float, channels: int) -> TextureModel:
        """Fit the PCA on normalised ``textures`` (S, M * C)."""
        return cls(fit_pca(textures, variance), channels)

    @property
    def n_modes(self) -> int:
        return self.pca.n_modes

    @property
    def mean(self) -> np.ndarray:
        return self.pca.mean

    def instance(self, b: np.ndarray) -> np.ndarray:
        """Normalised texture (M * C,) for parameters ``b`` (eq. 4.10)."""
        return self.pca.reconstruct(b)

    def params(self, g: np.ndarray) -> np.ndarray:
        """Parameters of a normalised texture (eq. 4.11)."""
        return self.pca.project(g)
