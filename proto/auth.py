"""Signatures of the messages only a run's own source may send: frames and the end of stream.

A launcher makes a secret key for each run and hands it to its processes in the
environment (``AAMTRACK_RUN_KEY``), never on a command line. The source signs what it
publishes; every process holding the key ignores (and counts) a ``frame`` or an ``eos``
on the stream's topic that does not carry the run's signature, so that another program
on the bus can neither number the run's frames (a frame 0 of another size would lock
the fitter on it) nor end the stream. The signature covers the message's identity (its
kind, stream, run, producer, frame index, capture and media times, and the frame's size
and encoding or the end's frame count and reason), not the pixels: HMAC-BLAKE2s, the
first :data:`proto.header.AUTH_HEX` hex digits.
"""

from __future__ import annotations

import hashlib
import hmac
from dataclasses import replace

import msgpack

from proto.header import AUTH_HEX
from proto.message import Message

ENV_KEY = "AAMTRACK_RUN_KEY"
"""The environment variable that holds a run's key (hex) for its processes."""
SIGNED = {"frame": ("width", "height", "encoding"), "eos": ("total_frames", "reason")}
"""The kinds a run signs, and the body fields each signature covers."""


def signature(key: bytes, message: Message) -> str:
    """The run's signature of ``message`` (a kind of :data:`SIGNED`)."""
    h = message.header
    identity = [message.KIND, h.stream_id, h.run_id, h.producer, h.frame_index,
                h.capture_time_ns, h.media_time_ns,
                *(getattr(message, name) for name in SIGNED[message.KIND])]
    digest = hmac.new(key, msgpack.packb(identity), hashlib.blake2s).hexdigest()
    return digest[:AUTH_HEX]


def signed(key: bytes, message: Message) -> Message:
    """``message`` with the run's signature in its header."""
    return replace(message, header=replace(message.header, auth=signature(key, message)))


def is_signed(key: bytes, message: Message) -> bool:
    """Whether ``message`` carries the run's signature."""
    return hmac.compare_digest(message.header.auth, signature(key, message))
