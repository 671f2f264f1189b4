"""The reference frame's box: the face inside its outline and a margin of what lies around it.

:class:`BoxWarp` samples an image over a rectangle of the reference frame
grown by a margin: each pixel inside the frame's mask as
:class:`~aamcore.warp.piecewise_affine.PiecewiseAffineWarp` samples it (the same
bilinear positions, so the same values), each pixel outside by the affine map of
the triangle of the nearest inside pixel, extended past the outline. One
``cv2.remap`` gives the face's texture and what borders it (the background at
the jaw, the hair above the brows), on which the occlusion test reads
gradients that the texture alone, cut at the outline, lacks.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage, sparse

from aamcore.warp.reference_frame import ReferenceFrame, barycentric


class BoxWarp:
    """Sample images over the frame's box grown by ``margin`` pixels on each side.

    Parameters
    ----------
    frame : ReferenceFrame
    n_points : int
    margin : int

    Attributes
    ----------
    size : (H, W)
        The box's size.
    inside : (M,) int64 array
        Flat index in the box of each of the frame's pixels (in the frame's order).
    origin : (2,) array
        Where the frame's pixel (0, 0) lies in the box.
    """

    def __init__(self, frame: ReferenceFrame, n_points: int, margin: int) -> None:
        height, width = frame.size
        self.frame = frame
        self.margin = margin
        self.size = (height + 2 * margin, width + 2 * margin)
        self.origin = np.array([margin, margin], np.float64)
        box_h, box_w = self.size
        index = np.full((box_h, box_w), -1, np.int64)
        xy = frame.pixels.astype(np.int64) + margin
        index[xy[:, 1], xy[:, 0]] = np.arange(frame.n_pixels)
        self.inside = xy[:, 1] * box_w + xy[:, 0]
        _, (iy, ix) = ndimage.distance_transform_edt(index < 0, return_indices=True)
        nearest = index[iy, ix].ravel()
        which = frame.pixel_triangle[nearest]
        ys, xs = np.mgrid[0:box_h, 0:box_w]
        centres = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64) - margin
        weights = barycentric(centres, frame.vertices, frame.triangles, which)
        weights[self.inside] = frame.weights  # the inside pixels exactly as the frame's warp
        rows = np.repeat(np.arange(box_h * box_w), 3)
        cols = frame.triangles[which].ravel()
        self.weights = sparse.csr_matrix((weights.ravel(), (rows, cols)),
                                         shape=(box_h * box_w, n_points))
        self._maps = np.empty((box_h, box_w, 2), np.float32)

    def sample(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """The box (H, W[, C]) of ``image`` at landmarks ``shape`` (N, 2), in the image's
        dtype; positions outside the image repeat its border."""
        self._maps.reshape(-1, 2)[:] = self.weights @ shape
        return cv2.remap(image, self._maps, None, interpolation=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)
