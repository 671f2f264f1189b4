"""Piecewise-affine warps between images and the reference frame (Algorithm 3).

:class:`PiecewiseAffineWarp` samples an image into the reference frame: each
inside pixel of the frame has fixed barycentric weights in its triangle, so
its source position is a fixed linear function of the landmarks; a sparse
``(M, N)`` matrix turns the landmarks into sampling maps for ``cv2.remap``
(bilinear). :func:`render_texture` goes the other way, painting a
reference-frame texture onto an image at a given shape.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import sparse

from aamcore.warp.reference_frame import ReferenceFrame, barycentric, rasterise_triangles

# cv2.remap wants maps under 32767 columns: lay the M samples out in rows.
_MAP_COLUMNS = 256


class PiecewiseAffineWarp:
    """Sample images into a :class:`ReferenceFrame`.

    Parameters
    ----------
    frame : ReferenceFrame
    n_points : int
        Number of landmarks.

    Notes
    -----
    Costly set-up (the weight matrix, the map buffers) happens here; per call
    :meth:`warp` does one sparse product and one ``cv2.remap``. The map buffer
    is reused, so an instance serves one thread at a time.
    """

    def __init__(self, frame: ReferenceFrame, n_points: int) -> None:
        self.frame = frame
        m = frame.n_pixels
        rows = np.repeat(np.arange(m), 3)
        cols = frame.triangles[frame.pixel_triangle].ravel()
        self.weights = sparse.csr_matrix((frame.weights.ravel(), (rows, cols)), shape=(m, n_points))
        self._rows = -(-m // _MAP_COLUMNS)
        self._maps = np.zeros((self._rows * _MAP_COLUMNS, 2), dtype=np.float32)
        self._map_view = self._maps.reshape(self._rows, _MAP_COLUMNS, 2)

    @property
    def n_pixels(self) -> int:
        return self.frame.n_pixels

    def source_coords(self, shape: np.ndarray) -> np.ndarray:
        """Image positions (M, 2) that the frame's pixels sample for ``shape`` (N, 2)."""
        return self.weights @ shape

    def warp(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Texture of ``image`` inside ``shape`` (N, 2), as (M, C) float32 (or (M,) if grey).

        Pixels whose source lies outside the image repeat the border.
        """
        m = self.frame.n_pixels
        self._maps[:m] = self.weights @ shape
        sampled = cv2.remap(
            image,
            self._map_view,
            None,
            interpolation=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_REPLICATE,
        )
        flat = sampled.reshape(self._rows * _MAP_COLUMNS, -1)[:m]
        flat = flat.astype(np.float32, copy=False)
        return flat[:, 0] if image.ndim == 2 else flat

    def warp_image(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Warp into the frame as an image (H, W[, C]), zero outside the mask."""
        return self.frame.to_image(self.warp(image, shape))


def sample_points(image: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """Bilinear samples (K, C) or (K,) of ``image`` at ``coords`` (K, 2), border repeated."""
    k = len(coords)
    rows = max(-(-k // _MAP_COLUMNS), 1)
    maps = np.zeros((rows * _MAP_COLUMNS, 2), dtype=np.float32)
    maps[:k] = coords
    sampled = cv2.remap(
        image,
        maps.reshape(rows, _MAP_COLUMNS, 2),
        None,
        interpolation=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    flat = sampled.reshape(rows * _MAP_COLUMNS, -1)[:k]
    return flat[:, 0] if image.ndim == 2 else flat


def render_texture(
    frame: ReferenceFrame, texture: np.ndarray, shape: np.ndarray, canvas: np.ndarray
) -> np.ndarray:
    """Paint a frame texture onto ``canvas`` at ``shape`` (the inverse warp).

    Parameters
    ----------
    frame : ReferenceFrame
    texture : (M, C) or (M,) array
        A texture in the frame, in the canvas's value range.
    shape : (N, 2) array
        Where the frame's vertices land on the canvas.
    canvas : (H, W[, C]) array
        Image painted in place (and returned).
    """
    height, width = canvas.shape[:2]
    x0, y0 = np.maximum(np.floor(shape.min(axis=0)).astype(int), 0)
    x1, y1 = np.minimum(np.ceil(shape.max(axis=0)).astype(int), [width - 1, height - 1])
    if x1 < x0 or y1 < y0:
        return canvas
    local = shape - [x0, y0]
    index = rasterise_triangles(local, frame.triangles, (y1 - y0 + 1, x1 - x0 + 1))
    ys, xs = np.nonzero(index >= 0)
    which = index[ys, xs]
    points = np.stack([xs, ys], axis=1).astype(np.float64)
    bary = barycentric(points, local, frame.triangles, which)
    tri = frame.triangles[which]
    ref = sum(bary[:, [k]] * frame.vertices[tri[:, k]] for k in range(3))
    values = sample_points(frame.to_image(texture.astype(np.float32)), ref)
    values = values.reshape(len(points), *canvas.shape[2:])
    canvas[ys + y0, xs + x0] = values.astype(canvas.dtype) if canvas.dtype != np.float32 else values
    return canvas
