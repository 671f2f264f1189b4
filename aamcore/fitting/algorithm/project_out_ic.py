"""Project-out inverse compositional fitting (Matthews & Baker 2004).

The shape is ``s0 + Q q``: the mean shape plus an orthonormal basis ``Q`` of
the four similarity directions and the shape modes. The steepest-descent
images of the mean texture, with the texture modes projected out, and their
Hessian are computed once; each iteration samples the image, multiplies the
error by the precomputed ``H^-1 SD^T``, and composes the inverse increment
with the current piecewise-affine warp. The appearance parameters of the
result come from the final shape and texture, so the failure test of eq. 7.2
applies as for :class:`~aamcore.fitting.algorithm.FixedJacobian`.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from aamcore.fitting.algorithm.base import AlgorithmSettings, ModelAlgorithm
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.model.aam import AAM
from aamcore.model.similarity import Similarity

if TYPE_CHECKING:
    from aamcore.fitting.model import FittingModel

MAX_ITERATIONS = 30


def shape_basis(mean: np.ndarray, modes: np.ndarray) -> np.ndarray:
    """Orthonormal basis (2N, 4 + k) of similarity directions then shape ``modes`` (2N, k)."""
    x, y = mean[:, 0], mean[:, 1]
    n = len(mean)
    similarity = np.stack(
        [
            mean.ravel(),
            np.stack([-y, x], 1).ravel(),
            np.tile([1.0, 0.0], n),
            np.tile([0.0, 1.0], n),
        ],
        axis=1,
    )
    q, _ = np.linalg.qr(np.hstack([similarity, modes]))
    return q


def texture_gradient(frame_image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Gradients (H, W, C, 2) of a frame image (H, W, C), the outside filled by nearest values."""
    _, (iy, ix) = ndimage.distance_transform_edt(~mask, return_indices=True)
    filled = frame_image[iy, ix]
    gy, gx = np.gradient(filled, axis=(0, 1))
    return np.stack([gx, gy], axis=-1)


class ProjectOutInverseCompositional(ModelAlgorithm):
    """Fit the shape by project-out inverse composition on the mean texture.

    Parameters
    ----------
    aam : AAM
    settings : AlgorithmSettings, optional
        At most ``settings.max_iterations`` iterations (:data:`MAX_ITERATIONS` by default).
    """

    name = "project-out-ic"

    def __init__(self, aam: AAM, settings: AlgorithmSettings | None = None) -> None:
        super().__init__(aam, settings)
        self.max_iterations = (settings and settings.max_iterations) or MAX_ITERATIONS
        frame = aam.frame
        self.mean_shape = aam.shape.mean_shape
        self.s0 = frame.vertices  # mean shape in frame pixels
        self.Q = shape_basis(self.mean_shape, aam.shape.pca.components)
        n_q = self.Q.shape[1]
        Qs = self.Q.reshape(-1, 2, n_q)

        channels = aam.channels
        m = frame.n_pixels
        a0 = aam.texture.mean.reshape(m, channels)
        grad = texture_gradient(frame.to_image(a0), frame.mask)[frame.mask]  # (M, C, 2)
        tri = frame.triangles[frame.pixel_triangle]  # (M, 3)
        dwdq = np.einsum("mk,mkdq->mdq", frame.weights, Qs[tri])  # (M, 2, n_q)
        sd = np.einsum("mcd,mdq->mcq", grad, dwdq).reshape(m * channels, n_q)

        # Project out the texture modes and the normalisation directions.
        ones = np.ones((m * channels, 1))
        basis, _ = np.linalg.qr(
            np.hstack([ones, aam.texture.mean[:, None], aam.texture.pca.components])
        )
        sd_po = sd - basis @ (basis.T @ sd)
        hessian = sd_po.T @ sd_po
        self.R = np.ascontiguousarray(np.linalg.solve(hessian, sd_po.T), dtype=np.float32)
        self.a0 = aam.texture.mean.astype(np.float32)
        self.texture_basis = np.ascontiguousarray(basis, dtype=np.float32)

        # Vertex -> triangles containing it, to carry points through a warp.
        self._vertex_triangles = [
            np.flatnonzero(np.any(frame.triangles == v, axis=1)) for v in range(len(self.s0))
        ]

    @classmethod
    def from_model(
        cls, model: FittingModel, settings: AlgorithmSettings
    ) -> ProjectOutInverseCompositional:
        """The fitter of ``model``'s AAM (it learns nothing beyond the AAM)."""
        return cls(model.aam, settings)

    def _affines(self, shape: np.ndarray) -> np.ndarray:
        """Affine maps (T, 2, 3) from each frame triangle to its image triangle."""
        tri = self.aam.frame.triangles
        src = np.concatenate([self.s0[tri], np.ones((len(tri), 3, 1))], axis=2)  # (T, 3, 3)
        dst = shape[tri]  # (T, 3, 2)
        return np.transpose(np.linalg.solve(src, dst), (0, 2, 1))

    def compose(self, shape: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Image shape after composing the inverse increment ``-dq`` with the warp to ``shape``."""
        moved = self.s0 - (self.Q @ dq).reshape(-1, 2)
        affines = self._affines(shape)
        out = np.empty_like(shape)
        for v, tris in enumerate(self._vertex_triangles):
            a = affines[tris]
            out[v] = (a[:, :, :2] @ moved[v] + a[:, :, 2]).mean(axis=0)
        return out

    def track(self, image: np.ndarray, previous: LandmarkFit) -> AAMFit:
        """Fit from the previous frame's landmarks."""
        return self.run_from_shape(image, previous.points)

    def run(self, image: np.ndarray, c0: np.ndarray, start: Similarity) -> AAMFit:
        """Fit from the shape of ``(c0, start)`` on a prepared ``image``."""
        return self.run_from_shape(image, self.residual.shape(c0, start.params))

    def run_from_shape(self, image: np.ndarray, shape: np.ndarray) -> AAMFit:
        """Fit from a start ``shape`` (N, 2) on a prepared ``image``."""
        shape_model = self.aam.shape
        b, sim = shape_model.fit_points(shape)
        shape = sim.apply(shape_model.instance(b))
        errors, seconds = [], []
        best = (np.inf, shape, b, sim)
        iterations, converged = 0, False
        for _ in range(self.max_iterations):
            begun = time.perf_counter()
            e = self.residual.image_texture(image, shape) - self.a0
            e_po = e - self.texture_basis @ (self.texture_basis.T @ e)
            error = float(e_po @ e_po) / e_po.size
            errors.append(error)
            if error < best[0]:
                best = (error, shape, b, sim)
            elif error > best[0] * 1.5:
                break
            dq = (self.R @ e).astype(np.float64)
            target = self.compose(shape, dq)
            b, sim = shape_model.fit_points(target, iterations=2)
            shape = sim.apply(shape_model.instance(b))
            iterations += 1
            seconds.append(time.perf_counter() - begun)
            if np.abs(self.Q @ dq).max() < 0.02:  # under 1/50 px per point
                converged = True
                break
        error, shape, b, sim = best
        g = self.residual.image_texture(image, shape)
        c = self.aam.combined.params(b, self.aam.texture.params(g.astype(np.float64)))
        return self.result(shape, c, sim, g - self.residual.model_texture(c),
                           iterations=iterations, converged=converged, errors=errors,
                           seconds=seconds)
