"""Image pyramids for multi-resolution fitting."""

from __future__ import annotations

import cv2
import numpy as np


def pyramid(image: np.ndarray, levels: int) -> list[np.ndarray]:
    """The image and ``levels - 1`` successive halvings of it."""
    out = [image]
    for _ in range(levels - 1):
        out.append(cv2.pyrDown(out[-1]))
    return out
