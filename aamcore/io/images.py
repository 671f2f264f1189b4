"""Bring any input image to the 8-bit layout a model works in."""

from __future__ import annotations

import cv2
import numpy as np


def to_uint8(image: np.ndarray) -> np.ndarray:
    """Convert an integer or float image to uint8.

    16-bit images are scaled by 1/257; float images are taken as 0-1 if their
    maximum is at most 1, else 0-255.

    Raises
    ------
    ValueError
        For an empty image, a non-finite float image or an unsupported dtype.
    """
    image = np.asarray(image)
    if image.size == 0:
        raise ValueError("empty image")
    if image.dtype == np.uint8:
        return image
    if image.dtype == np.uint16:
        return (image // 257).astype(np.uint8)
    if np.issubdtype(image.dtype, np.floating):
        if not np.all(np.isfinite(image)):
            raise ValueError("image has NaN or infinite values")
        scale = 255.0 if image.max() <= 1.0 else 1.0
        return np.clip(image * scale + 0.5, 0, 255).astype(np.uint8)
    if np.issubdtype(image.dtype, np.integer):
        return np.clip(image, 0, 255).astype(np.uint8)
    raise ValueError(f"unsupported image dtype {image.dtype}")


def to_channels(image: np.ndarray, channels: int) -> np.ndarray:
    """Return ``image`` as uint8 grey (H, W) for 1 channel or BGR (H, W, 3) for 3.

    Accepts grey, BGR and BGRA input of any dtype :func:`to_uint8` takes.
    """
    image = to_uint8(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[..., 0]
    if image.ndim == 2:
        return image if channels == 1 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if image.ndim != 3 or image.shape[2] not in (3, 4):
        raise ValueError(f"unsupported image shape {image.shape}")
    if image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if channels == 1 else image
