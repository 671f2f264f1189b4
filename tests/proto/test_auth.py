"""proto.auth: a run signs its frames and its end of stream; nothing else passes for them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from proto import EndOfStream, Frame, Header, decode, encode
from proto.auth import is_signed, signature, signed
from proto.limits import ProtoError

KEY = bytes(range(16))


def _eos(total: int = 43) -> EndOfStream:
    header = Header("cam0", 42, 1_700_000_000_000_000_000, "source", 1_700_000_000_005_000_000,
                    "run-8f3a2c", 1_680_000_000)
    return EndOfStream(header, total_frames=total, reason="end_of_file")


def test_a_signed_message_passes_and_survives_the_wire() -> None:
    eos = signed(KEY, _eos())
    assert len(eos.header.auth) == 32 and is_signed(KEY, eos)
    assert is_signed(KEY, decode(encode(eos), "eos"))
    # A test vector for other implementations (proto/README.md, "Signatures").
    assert signature(KEY, _eos()) == eos.header.auth == signature(KEY, decode(encode(eos)))


def test_what_the_signature_covers_cannot_be_changed() -> None:
    eos = signed(KEY, _eos())
    assert not is_signed(KEY, _eos())  # unsigned
    assert not is_signed(bytes(16), eos)  # another run's key
    assert not is_signed(KEY, replace(eos, total_frames=1))
    assert not is_signed(KEY, replace(eos, header=replace(eos.header, frame_index=0)))
    frame = signed(KEY, Frame.from_array(_eos().header, np.zeros((24, 32, 3), np.uint8)))
    assert is_signed(KEY, frame)
    bigger = Frame.from_array(frame.header, np.zeros((48, 64, 3), np.uint8))
    assert not is_signed(KEY, bigger)  # the signed header on a frame of another size


def test_a_malformed_signature_is_refused_on_decode() -> None:
    with pytest.raises(ProtoError, match="header.auth: expected empty or 32 lower-case hex"):
        replace(_eos().header, auth="xyz")
