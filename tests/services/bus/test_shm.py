"""services.bus.shm: an image message written once into a real Zenoh shared-memory pool, its
bytes those of the message; over the network, counted by reason, where the pool cannot."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from proto import Frame, Header, decode, encode
from proto.codec import encode_parts
from services.bus.shm import SharedImages

LOG = logging.getLogger("test-shm")


def frame(side: int = 64, in_bytearray: bool = True) -> Frame:
    shape = (side, side, 3)
    image = (np.frombuffer(bytearray(side * side * 3), np.uint8).reshape(shape)
             if in_bytearray else np.zeros(shape, np.uint8))
    image[...] = np.arange(image.size, dtype=np.uint64).reshape(shape) % 251
    return Frame.from_array(Header.now("cam0", 3, "source"), image)


def test_a_frame_is_written_once_and_reads_back_as_the_message() -> None:
    images = SharedImages(4, LOG)  # room for four
    message = frame()
    payload = images.payload(encode_parts(message))
    assert payload.as_shm() is not None  # a shared-memory buffer, not bytes
    assert payload.to_bytes() == encode(message)
    assert np.array_equal(decode(payload.to_bytes(), "frame").image, message.image)
    assert images.shared == 1 and images.copied == 0 and images.fallbacks == 0
    # Pixels that do not lie in a bytearray are copied once more, and counted.
    images.payload(encode_parts(frame(in_bytearray=False)))
    assert images.shared == 2 and images.copied == 1


def test_a_full_pool_sends_over_the_network_and_recovers_once_buffers_are_free(
        caplog: pytest.LogCaptureFixture) -> None:
    message = frame(side=256)  # 196,608 bytes of pixels
    images = SharedImages(2, LOG)  # room for two
    with caplog.at_level(logging.INFO):
        held = [images.payload(encode_parts(message)) for _ in range(4)]
    assert [not isinstance(p, bytes) for p in held] == [True, True, False, False]
    assert held[2] == encode(message) and images.network == {"full": 2}
    # a moment's lag of the readers (a loaded machine) is said once, not warned of
    assert [(r.levelno, "pool is full" in r.getMessage()) for r in caplog.records] == [
        (logging.INFO, True)]
    with caplog.at_level(logging.INFO):  # a reader that keeps holding them is warned of
        held += [images.payload(encode_parts(message)) for _ in range(3 * 2 + 3)]
    warned = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warned) == 1 and "full for 6 images in a row" in warned[0].getMessage()
    held.clear()  # the readers let go: the pool is used again
    assert not isinstance(images.payload(encode_parts(message)), bytes)
    assert images.line() == "images in shared memory 3, over the network 11 (full 11)"
    assert images.pool_bytes < 3 * len(encode(message))  # sized by the first image


def test_a_pool_too_small_or_none_sends_every_image_over_the_network() -> None:
    """The pool is sized by its first image: a larger one later (a JPEG's size varies) goes
    over the network."""
    message = frame()
    small = SharedImages(1, LOG)
    assert not isinstance(small.payload(encode_parts(frame(side=16))), bytes)
    assert small.payload(encode_parts(message)) == encode(message)
    assert small.network == {"too small": 1} and small.fallbacks == 1
    off = SharedImages(0, LOG)
    assert off.payload(encode_parts(message)) == encode(message)
    assert off.network == {"off": 1} and off.fallbacks == 0  # asked for: no fall-back
