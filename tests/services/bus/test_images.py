"""services.bus.images: JPEG frames are decoded and their size checked."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from proto import Frame, Header, ProtoError
from services.bus.images import image_of


def test_image_of_decodes_jpeg_and_checks_its_size() -> None:
    image = np.zeros((40, 60, 3), np.uint8)
    image[10:30, 20:40] = 200
    data = cv2.imencode(".jpg", image)[1].tobytes()
    header = Header.now("cam0", 0, "x")
    decoded = image_of(Frame.from_jpeg(header, data, 60, 40))
    assert decoded.shape == (40, 60, 3) and abs(int(decoded[20, 30, 0]) - 200) < 8
    with pytest.raises(ProtoError, match="message says 61 x 40"):
        image_of(Frame.from_jpeg(header, data, 61, 40))
    with pytest.raises(ProtoError, match="does not decode"):
        image_of(Frame.from_jpeg(header, b"\xff\xd8\xff" + b"\x00" * 20, 60, 40))
    raw = Frame.from_array(header, image)
    assert image_of(raw) is raw.image
