"""Test videos: the frames OpenCV decodes from a file, and MP4 files with their index (the
``moov`` box) at the front, as streaming encoders write them (``ffmpeg -movflags
+faststart``): half of such a file still states every frame."""

from __future__ import annotations

import struct
from pathlib import Path

import cv2

CONTAINERS = {b"moov", b"trak", b"mdia", b"minf", b"stbl"}
"""Boxes holding the chunk offset tables (``stco``, ``co64``) somewhere below them."""


def _boxes(data: bytes | bytearray, start: int, end: int) -> list[tuple[bytes, int, int]]:
    """``(type, offset, size)`` of each box from ``start`` to ``end``."""
    found, at = [], start
    while at + 8 <= end:
        size, kind = struct.unpack(">I4s", data[at:at + 8])
        if size == 1:
            size = struct.unpack(">Q", data[at + 8:at + 16])[0]
        elif size == 0:
            size = end - at
        found.append((kind, at, size))
        at += size
    return found


def _shift_offsets(moov: bytearray, start: int, end: int, shift: int) -> None:
    for kind, at, size in _boxes(moov, start, end):
        if kind in CONTAINERS:
            _shift_offsets(moov, at + 8, at + size, shift)
        elif kind in (b"stco", b"co64"):
            count = struct.unpack(">I", moov[at + 12:at + 16])[0]
            fmt, width = (">I", 4) if kind == b"stco" else (">Q", 8)
            for k in range(count):
                pos = at + 16 + k * width
                moov[pos:pos + width] = struct.pack(fmt, struct.unpack(fmt, moov[
                    pos:pos + width])[0] + shift)


def faststart(mp4: bytes) -> bytes:
    """The same movie with its ``moov`` box right after ``ftyp`` (chunk offsets moved)."""
    boxes = _boxes(mp4, 0, len(mp4))
    kinds = [kind for kind, _, _ in boxes]
    if kinds[:2] == [b"ftyp", b"moov"]:
        return mp4
    _, at, size = boxes[kinds.index(b"moov")]
    moov = bytearray(mp4[at:at + size])
    _shift_offsets(moov, 8, size, size)
    rest = [mp4[a:a + s] for kind, a, s in boxes if kind not in (b"ftyp", b"moov")]
    _, first, first_size = boxes[0]
    return mp4[first:first + first_size] + bytes(moov) + b"".join(rest)


def decoded_frames(video: Path) -> int:
    """Frames OpenCV decodes from ``video`` (container counts can be off)."""
    capture = cv2.VideoCapture(str(video))
    frames = 0
    while capture.read()[0]:
        frames += 1
    capture.release()
    return frames
