"""The texture residual ``r = g_image - g_model`` of a model instance (eq. 6.19)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from aamcore.model.aam import AAM
from aamcore.model.similarity import apply_pose

WarpFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


class ResidualFunction:
    """Evaluate residuals of one AAM against one image.

    Parameters
    ----------
    aam : AAM
    warp : callable, optional
        ``warp(image, shape) -> (M, C)`` texture; the AAM's CPU warp by default
        (the GPU-warp worker offers the same call).

    Notes
    -----
    The model's bases are kept as float32 so that the two matrix-vector
    products per evaluation stay cheap.
    """

    def __init__(self, aam: AAM, warp: WarpFn | None = None) -> None:
        self.aam = aam
        self.warp = warp or aam.warp.warp
        self.shape_mean = aam.shape.pca.mean.reshape(-1, 2)
        self.shape_basis = aam.shape_basis.reshape(-1, 2, aam.n_appearance)
        self.texture_mean = aam.texture.mean.astype(np.float32)
        self.texture_basis = np.ascontiguousarray(aam.texture_basis, dtype=np.float32)

    def shape(self, c: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Image shape (N, 2) of ``(c, t)``."""
        return apply_pose(t, self.shape_mean + self.shape_basis @ c)

    def image_texture(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Normalised texture (M C,) float32 sampled from ``image`` inside ``shape``."""
        g = self.warp(image, shape).ravel()
        g = g - g.mean()
        std = g.std()
        return g / std if std > 1e-6 else g

    def model_texture(self, c: np.ndarray) -> np.ndarray:
        """Model texture (M C,) float32 of ``c``."""
        return self.texture_mean + self.texture_basis @ c.astype(np.float32)

    def __call__(self, image: np.ndarray, c: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, float]:
        """Residual (M C,) and its error ``mean(r^2)`` at ``(c, t)``."""
        r = self.image_texture(image, self.shape(c, t)) - self.model_texture(c)
        return r, float(r @ r) / r.size


def per_pixel(residual: np.ndarray, channels: int) -> np.ndarray:
    """A texture residual (M C,) as one float32 value per pixel (M,): for a colour model the
    root mean square over the channels, signed by their mean."""
    r = np.asarray(residual, np.float32)
    if channels == 1:
        return r
    r = r.reshape(-1, channels)
    return (np.sign(r.mean(axis=1)) * np.sqrt((r * r).mean(axis=1))).astype(np.float32)
