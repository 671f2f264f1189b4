"""Dense gradient features of a face in the reference frame.

Raw pixels describe in-the-wild faces poorly (STACK_NOTES: about one raw-pixel
AAM fit in five fails on LFPW); histograms of oriented gradients (HOG) over
the shape-normalised face are far more robust to lighting and cheap to compute
with OpenCV.
"""

from __future__ import annotations

import cv2
import numpy as np

from aamcore.warp.reference_frame import ReferenceFrame


class FrameHog:
    """HOG descriptor of a grey texture laid out in a reference frame.

    Parameters
    ----------
    frame : ReferenceFrame
    cell : int
        HOG cell size in frame pixels; blocks are 2x2 cells, strided by a cell.
    bins : int
        Orientation bins.
    """

    def __init__(self, frame: ReferenceFrame, cell: int = 12, bins: int = 9) -> None:
        self.frame = frame
        height, width = frame.size
        self.win = (
            (width - 2 * cell) // cell * cell + 2 * cell,
            (height - 2 * cell) // cell * cell + 2 * cell,
        )
        if self.win[0] > width or self.win[1] > height or min(self.win) < 2 * cell:
            raise ValueError(f"reference frame {width}x{height} too small for HOG cells of {cell}")
        self.origin = ((width - self.win[0]) // 2, (height - self.win[1]) // 2)
        self.hog = cv2.HOGDescriptor(
            self.win, (2 * cell, 2 * cell), (cell, cell), (cell, cell), bins
        )
        self._image = np.zeros((height, width), dtype=np.uint8)
        self._ys, self._xs = np.nonzero(frame.mask)
        self.size = int(self.hog.getDescriptorSize())

    def __call__(self, texture: np.ndarray) -> np.ndarray:
        """HOG vector (D,) float32 of a grey frame texture (M,) with values 0-255.

        Pixels outside the face take the face's mean so that the mask outline
        adds no gradient of its own.
        """
        image = self._image
        image[:] = int(np.clip(texture.mean(), 0, 255))
        image[self._ys, self._xs] = np.clip(texture, 0, 255)
        x, y = self.origin
        window = image[y : y + self.win[1], x : x + self.win[0]]
        return self.hog.compute(np.ascontiguousarray(window)).ravel()
