"""The texture reference frame: the mean shape, its triangles and its pixels.

The mean shape is triangulated once (Delaunay, thesis section 4.2.1) and those
triangles are kept for every later warp: re-triangulating a deformed shape can
give a different triangulation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay

MARGIN = 1.0


def delaunay_triangles(points: np.ndarray) -> np.ndarray:
    """Delaunay triangles of ``points`` (N, 2), as (T, 3) int32 vertex indices."""
    return Delaunay(points).simplices.astype(np.int32)


def triangle_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Areas (T,) of ``triangles`` (T, 3) over ``points`` (N, 2)."""
    a, b, c = (points[triangles[:, i]] for i in range(3))
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    return 0.5 * np.abs(cross)


def barycentric(
    points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray, which: np.ndarray
) -> np.ndarray:
    """Barycentric coordinates (M, 3) of ``points`` (M, 2) in triangles ``which`` (M,).

    Implements eqs. 4.3-4.5: ``x = alpha x1 + beta x2 + gamma x3``.
    """
    tri = triangles[which]
    p1, p2, p3 = vertices[tri[:, 0]], vertices[tri[:, 1]], vertices[tri[:, 2]]
    v1, v2, v = p2 - p1, p3 - p1, points - p1
    det = v1[:, 0] * v2[:, 1] - v1[:, 1] * v2[:, 0]
    beta = (v[:, 0] * v2[:, 1] - v[:, 1] * v2[:, 0]) / det
    gamma = (v1[:, 0] * v[:, 1] - v1[:, 1] * v[:, 0]) / det
    return np.stack([1.0 - beta - gamma, beta, gamma], axis=1)


def rasterise_triangles(
    vertices: np.ndarray, triangles: np.ndarray, size: tuple[int, int]
) -> np.ndarray:
    """Image (H, W) int32 of the triangle covering each pixel centre, -1 outside.

    Parameters
    ----------
    vertices : (N, 2) array
        Triangle vertices in pixel coordinates.
    triangles : (T, 3) int array
    size : (H, W)
    """
    height, width = size
    ys, xs = np.mgrid[0:height, 0:width]
    centres = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
    index = np.full(height * width, -1, dtype=np.int32)
    lo = np.floor(vertices[triangles].min(axis=1)).astype(int)
    hi = np.ceil(vertices[triangles].max(axis=1)).astype(int)
    for t in range(len(triangles)):
        x0, y0 = max(lo[t, 0], 0), max(lo[t, 1], 0)
        x1, y1 = min(hi[t, 0], width - 1), min(hi[t, 1], height - 1)
        if x1 < x0 or y1 < y0:
            continue
        yy, xx = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
        flat = (yy * width + xx).ravel()
        free = flat[index[flat] < 0]
        bary = barycentric(centres[free], vertices, triangles, np.full(len(free), t))
        inside = np.all(bary >= -1e-9, axis=1)
        index[free[inside]] = t
    return index.reshape(height, width)


@dataclass(frozen=True)
class ReferenceFrame:
    """The shape-normalised frame in which textures are sampled.

    Attributes
    ----------
    vertices : (N, 2) array
        The mean shape in frame pixel coordinates.
    triangles : (T, 3) int32 array
    size : (H, W)
    mask : (H, W) bool array
        Pixels inside the triangulated mean shape.
    pixels : (M, 2) float64 array
        ``(x, y)`` of the inside pixels, row-major order.
    pixel_triangle : (M,) int32 array
        Triangle holding each inside pixel.
    weights : (M, 3) float64 array
        Barycentric coordinates of each inside pixel in its triangle.
    offset : (2,) array
        Model-frame origin in frame pixels: ``frame = model + offset``.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    size: tuple[int, int]
    mask: np.ndarray
    pixels: np.ndarray
    pixel_triangle: np.ndarray
    weights: np.ndarray
    offset: np.ndarray

    @classmethod
    def from_mean_shape(
        cls, model_mean: np.ndarray, triangles: np.ndarray | None = None
    ) -> ReferenceFrame:
        """Build the frame around ``model_mean`` (N, 2), triangulating it if needed."""
        if triangles is None:
            triangles = delaunay_triangles(model_mean)
        offset = MARGIN - model_mean.min(axis=0)
        vertices = model_mean + offset
        width, height = (int(np.ceil(v)) + 1 + int(MARGIN) for v in vertices.max(axis=0))
        index = rasterise_triangles(vertices, triangles, (height, width))
        mask = index >= 0
        ys, xs = np.nonzero(mask)
        pixels = np.stack([xs, ys], axis=1).astype(np.float64)
        which = index[ys, xs]
        weights = barycentric(pixels, vertices, triangles, which)
        return cls(vertices, triangles, (height, width), mask, pixels, which, weights, offset)

    @property
    def n_pixels(self) -> int:
        return len(self.pixels)

    def to_image(self, texture: np.ndarray, background: float = 0.0) -> np.ndarray:
        """Lay a texture (M, C) or (M,) out as an image (H, W, C) or (H, W)."""
        shape = self.size + texture.shape[1:]
        image = np.full(shape, background, dtype=texture.dtype)
        image[self.mask] = texture
        return image


def scale_for_pixels(unit_mean: np.ndarray, triangles: np.ndarray, n_pixels: int) -> float:
    """Scale making the triangulated ``unit_mean`` (N, 2) cover about ``n_pixels``."""
    area = float(triangle_areas(unit_mean, triangles).sum())
    if area <= 0:
        raise ValueError("degenerate mean shape: zero area")
    return float(np.sqrt(n_pixels / area))
