"""The pixels of a frame or overlay message, raw or JPEG."""

from __future__ import annotations

import numpy as np

from proto import ProtoError
from proto.messages import Frame, Overlay


def image_of(message: Frame | Overlay) -> np.ndarray:
    """The pixels of a frame or overlay: ``(H, W, 3)`` BGR or ``(H, W)`` grey uint8.

    Raises
    ------
    ProtoError
        When JPEG data does not decode or decodes to another size than the
        message says.
    """
    if isinstance(message.image, np.ndarray):
        return message.image
    import cv2

    image = cv2.imdecode(np.frombuffer(message.image, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ProtoError(f"{message.KIND}.image: JPEG data does not decode")
    if image.shape[:2] != (message.height, message.width):
        raise ProtoError(
            f"{message.KIND}.image: JPEG is {image.shape[1]} x {image.shape[0]}, "
            f"message says {message.width} x {message.height}"
        )
    return image
