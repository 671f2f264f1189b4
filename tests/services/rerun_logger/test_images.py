"""Raw frames are compressed to JPEG; JPEG frames pass through unchanged."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from proto.golden import GREY_JPEG_8X8
from proto.messages import Frame, Overlay
from services.rerun_logger.images import encode_jpeg, message_jpeg


def _decode(data: bytes, flag: int = cv2.IMREAD_UNCHANGED) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(data, np.uint8), flag)


def test_encode_jpeg_keeps_a_real_face_close_and_small(faces):
    image = faces[0].load_image()
    data = encode_jpeg(image, quality=85)
    decoded = _decode(data)
    assert decoded.shape == image.shape
    assert np.abs(decoded.astype(int) - image).mean() < 4.0
    assert len(data) < image.nbytes / 4
    assert len(encode_jpeg(image, quality=20)) < len(data)


def test_encode_jpeg_of_a_grey_image(faces):
    grey = cv2.cvtColor(faces[1].load_image(), cv2.COLOR_BGR2GRAY)
    decoded = _decode(encode_jpeg(grey))
    assert decoded.shape == grey.shape


@pytest.mark.parametrize(
    ("image", "quality", "problem"),
    [
        (np.zeros((4, 4, 3), np.float32), 85, "uint8"),
        (np.zeros((4, 4, 4), np.uint8), 85, r"\(H, W, 3\)"),
        (np.zeros(4, np.uint8), 85, r"\(H, W\)"),
        (np.zeros((4, 4), np.uint8), 0, "quality 0"),
        (np.zeros((4, 4), np.uint8), 101, "quality 101"),
    ],
)
def test_encode_jpeg_rejects_bad_input(image, quality, problem):
    with pytest.raises(ValueError, match=problem):
        encode_jpeg(image, quality)


def test_message_jpeg_passes_jpeg_through_and_encodes_raw(faces, messages_of):
    overlay = Overlay.from_jpeg(messages_of(faces[0], 0)[0].header, GREY_JPEG_8X8, 8, 8)
    assert message_jpeg(overlay) is GREY_JPEG_8X8
    frame = messages_of(faces[0], 0)[0]
    assert isinstance(frame, Frame) and frame.encoding == "raw"
    assert _decode(message_jpeg(frame)).shape == frame.image.shape
