"""The AAM appearance of given landmarks, for the methods that find landmarks without the AAM.

The local-binary method finds landmarks without sampling the face's texture;
the fitter then gets the AAM's view of the face here: one texture warp inside
the landmarks (the GL worker's or the CPU's), projected on the texture model,
with the shape parameters of the landmarks, into the combined parameters
``c``; and the per-pixel texture residual ``g - g_model(c)`` of eq. 6.19, as
the AAM methods leave it after their last iteration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.fitting.residuals import ResidualFunction, WarpFn, per_pixel
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity


@dataclass(frozen=True)
class Projection:
    """The appearance of a face at given landmarks.

    Attributes
    ----------
    c : (t_c,) float64 array
        Combined appearance parameters.
    texture : (M C,) float32 array
        The normalised texture sampled.
    residual : (M,) float32 array
        ``g - g_model(c)`` per reference-frame pixel (see
        :attr:`aamcore.fitting.result.AAMFit.residual`).
    error : float
        Mean squared residual.
    similarity : Similarity
        The placement of ``c``'s shape on the landmarks (least squares).
    """

    c: np.ndarray
    texture: np.ndarray
    residual: np.ndarray
    error: float
    similarity: Similarity


ROI_MARGIN = 2
"""Pixels around the landmarks' box that a bilinear sample inside their hull may read."""


class AppearanceSampler:
    """Appearance ``c`` and texture residual of an AAM at landmarks.

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
        # c = (w b_s - mu_s) C_s + (b_g - mu_g) C_g with b_g = P^T (g - mean): the texture
        # part is (g - mean) @ (P C_g), the basis the residual needs anyway (one product of
        # t_c columns instead of the texture model's t_g).
        combined = aam.combined
        n_s = aam.shape.n_modes
        components, mean = combined.pca.components, combined.pca.mean
        self._shape_part = components[:n_s]
        self._shape_mean = mean[:n_s]
        self._offset = -mean[n_s:] @ components[n_s:]
        self._weight = combined.weight
        # the residual's own basis, transposed: one copy in the cache for both products
        self._texture_basis_t = self.residual.texture_basis.T

    def project(self, prepared: np.ndarray, points: np.ndarray) -> Projection:
        """The appearance at landmarks ``points`` (N, 2) of an image prepared for the AAM
        (:meth:`aamcore.model.aam.AAM.prepare_image`)."""
        g = self.residual.image_texture(prepared, points)
        b_s, sim = self.aam.shape.fit_points(points, iterations=2)
        c = ((self._weight * b_s - self._shape_mean) @ self._shape_part + self._offset
             + (self._texture_basis_t @ (g - self.texture_mean)).astype(np.float64))
        r = per_pixel(g - self.residual.model_texture(c), self.aam.channels)
        return Projection(c, g, r, float(r @ r) / r.size, sim)

    def project_frame(self, image: np.ndarray, points: np.ndarray) -> Projection:
        """:meth:`project` on a raw frame: only the face's box (the landmarks' bounding box
        and a pixel or two for the bilinear samples) is converted for the AAM, not the
        whole frame (a model that equalises the face, and the GPU path, get it all); the
        texture sampled is the same."""
        height, width = image.shape[:2]
        lo = np.floor(points.min(axis=0)).astype(int) - ROI_MARGIN
        hi = np.ceil(points.max(axis=0)).astype(int) + ROI_MARGIN + 1
        x0, y0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
        x1, y1 = min(int(hi[0]), width), min(int(hi[1]), height)
        on_gpu = getattr(self.residual.warp, "path", "cpu") == "gpu"
        if x1 - x0 < 2 or y1 - y0 < 2 or self.aam.equalise or on_gpu:
            # outside the frame, equalised over a region of its own, or uploaded to the GL
            # worker (a texture of the frame's size is reused; a box's changes every frame)
            return self.project(self.aam.prepare_image(image, points), points)
        local = points - np.array([x0, y0], np.float64)
        # a contiguous copy: OpenCV converts a strided view three times slower
        box = np.ascontiguousarray(image[y0:y1, x0:x1])
        found = self.project(self.aam.prepare_image(box, local), local)
        sim = found.similarity
        return Projection(found.c, found.texture, found.residual, found.error,
                          Similarity(sim.a, sim.b, sim.tx + x0, sim.ty + y0))

    def __call__(self, image: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, float]:
        """``c`` (t_c,) and the texture error of landmarks ``points`` (N, 2) on a raw
        ``image`` (prepared for the AAM here)."""
        found = self.project(self.aam.prepare_image(image, points), points)
        return found.c, found.error
