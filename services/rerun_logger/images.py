"""Frames and overlays as JPEG for the recording.

A raw 640 x 480 frame costs about 860 KB in an ``.rrd`` file and a JPEG about
44 KB (STACK_NOTES), so raw images are compressed before logging and JPEG
images are logged as they came.
"""

from __future__ import annotations

import cv2
import numpy as np

from proto.messages import Frame, Overlay
from services.rerun_logger.options import DEFAULT_QUALITY


def encode_jpeg(image: np.ndarray, quality: int = DEFAULT_QUALITY) -> bytes:
    """JPEG file bytes of a ``uint8`` image.

    Parameters
    ----------
    image : numpy.ndarray
        ``(H, W, 3)`` BGR (OpenCV's order) or ``(H, W)`` grey, ``uint8``.
    quality : int
        JPEG quality, 1 to 100.

    Raises
    ------
    ValueError
        For an image of another shape or dtype, a quality out of range, or an
        image OpenCV cannot encode.
    """
    shape_ok = image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)
    if image.dtype != np.uint8 or not shape_ok:
        raise ValueError(f"expected a uint8 (H, W, 3) or (H, W) image, got {image.dtype} "
                         f"{image.shape}")
    if not 1 <= quality <= 100:
        raise ValueError(f"JPEG quality {quality} is outside 1 to 100")
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError(f"OpenCV could not encode a {image.shape} image as JPEG")
    return data.tobytes()


def message_jpeg(msg: Frame | Overlay, quality: int = DEFAULT_QUALITY) -> bytes:
    """The image of a frame or overlay message as JPEG bytes (raw ones are encoded)."""
    if isinstance(msg.image, bytes):
        return msg.image
    return encode_jpeg(msg.image, quality)
