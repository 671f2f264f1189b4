"""The AAM appearance ``c`` of given landmarks, for methods that fit without the AAM.

The local-binary method finds landmarks without sampling the face's texture; a
consumer of the appearance (expression recognition, the ``chi2`` failure test)
gets it here: one texture warp inside the landmarks, projected on the texture
model, with the shape parameters of the landmarks, as the supervised-descent
method computes it after its last stage.
"""

from __future__ import annotations

import numpy as np

from aamcore.fitting.residuals import ResidualFunction, WarpFn
from aamcore.model.aam import AAM


class AppearanceSampler:
    """Appearance ``c`` and texture error of an AAM at landmarks.

    Parameters
    ----------
    aam : AAM
    warp : callable, optional
        Texture sampler ``warp(image, shape) -> (M, C)``; the CPU warp by default.
    """

    def __init__(self, aam: AAM, warp: WarpFn | None = None) -> None:
        self.aam = aam
        self.residual = ResidualFunction(aam, warp)
        self.texture_mean = aam.texture.mean.astype(np.float32)
        self.texture_components = np.ascontiguousarray(aam.texture.pca.components, np.float32)

    def __call__(self, image: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, float]:
        """``c`` (t_c,) and the texture model's residual error of landmarks ``points`` (N, 2)
        on a raw ``image`` (prepared for the AAM here)."""
        prepared = self.aam.prepare_image(image, points)
        g = self.residual.image_texture(prepared, points)
        centred = g - self.texture_mean
        b_g = centred @ self.texture_components
        b_s, _ = self.aam.shape.fit_points(points, iterations=2)
        c = self.aam.combined.params(b_s, b_g.astype(np.float64))
        # the texture model's residual: its components are orthonormal
        error = max(float(centred @ centred - b_g @ b_g), 0.0) / g.size
        return c, error
