"""proto.auth: every message signed by its producer's key, over the header and the body as it
travels; nothing else passes for it."""

from __future__ import annotations

from dataclasses import replace

import msgpack
import numpy as np
import pytest

from proto import EndOfStream, Frame, Header, decode, encode
from proto.auth import (
    KEY_BYTES,
    Keyring,
    digest,
    encode_signed,
    encode_signed_parts,
    is_signed,
    sign_digest,
    verifies,
)
from proto.codec import encode_parts
from proto.limits import ProtoError

KEY = bytes(range(KEY_BYTES))


def _header(index: int = 42) -> Header:
    return Header("cam0", index, 1_700_000_000_000_000_000, "source", 1_700_000_000_005_000_000,
                  "run-8f3a2c", 1_680_000_000)


def _eos(total: int = 43) -> EndOfStream:
    return EndOfStream(_header(), total_frames=total, reason="end_of_file")


def _frame(image: np.ndarray) -> Frame:
    return Frame.from_array(_header(), image)


def test_a_signed_message_decodes_to_itself_and_passes() -> None:
    payload = encode_signed(KEY, _eos())
    eos = decode(payload, "eos")
    assert len(eos.header.auth) == 32 and is_signed(KEY, payload, eos)
    assert replace(eos, header=replace(eos.header, auth="")) == _eos()
    assert payload == encode(eos)  # laid out as the codec lays out any message
    # A test vector for other implementations: keyed BLAKE3 of the message's digest.
    assert eos.header.auth == "b62df60dbbc28c89c9ab868e7ca662c0"


def test_the_signature_covers_the_pixels_their_shape_and_channels() -> None:
    image = np.arange(24 * 32 * 3, dtype=np.uint8).reshape(24, 32, 3)
    payload = encode_signed(KEY, _frame(image))
    frame = decode(payload, "frame")
    assert is_signed(KEY, payload, frame)
    auth = frame.header.auth

    def resigned_header_on(other: Frame) -> bytes:
        """``other`` with the signed frame's header (and signature): the replay of issue 37."""
        return encode(replace(other, header=replace(other.header, auth=auth)))

    black = image.copy()
    black[5, 7, 1] ^= 1  # one bit of one pixel
    for other in (_frame(black), _frame(image.reshape(48, 16, 3)),
                  _frame(np.ascontiguousarray(image[:, :, 0]))):
        forged = resigned_header_on(other)
        assert not is_signed(KEY, forged, decode(forged, "frame"))


def test_another_key_a_cut_signature_or_a_changed_header_does_not_pass() -> None:
    payload = encode_signed(KEY, _eos())
    eos = decode(payload, "eos")
    assert not is_signed(bytes(KEY_BYTES), payload, eos)  # another run's key
    unsigned = encode(_eos())
    assert not is_signed(KEY, unsigned, decode(unsigned))
    for changed in (replace(eos, total_frames=1),
                    replace(eos, header=replace(eos.header, frame_index=0)),
                    replace(eos, header=replace(eos.header, producer="fitter"))):
        forged = encode(changed)
        assert not is_signed(KEY, forged, decode(forged))
    with pytest.raises(ProtoError, match="header.auth: expected empty or 32 lower-case hex"):
        replace(eos.header, auth=eos.header.auth[:31])  # a truncated signature is malformed


def test_a_header_re_encoded_otherwise_does_not_pass() -> None:
    """The header must be the canonical encoding: the bytes hashed are the bytes read."""
    payload = encode_signed(KEY, _eos())
    obj = msgpack.unpackb(payload)
    obj["header"] = dict(reversed(list(obj["header"].items())))  # same fields, other order
    obj["header"] = {"schema_version": obj["header"].pop("schema_version"),
                     "kind": obj["header"].pop("kind")} | obj["header"]
    other = msgpack.packb(obj)
    assert other != payload
    assert not is_signed(KEY, other, decode(other))


def test_a_keyring_gives_each_service_its_own_key_and_the_keys_of_what_it_reads() -> None:
    ring = Keyring.generate(["source", "fitter", "pose"])
    pose = ring.for_service("pose", ["fitter"])
    assert pose.signer == "pose" and set(pose.keys) == {"pose", "fitter"}
    assert Keyring.from_bytes(pose.to_bytes()) == pose
    source = ring.for_service("source", [])
    payload = source.encode(_eos())
    assert ring.problem(payload, decode(payload)) == ""
    assert pose.problem(payload, decode(payload)) == "not a service of the run"
    assert Keyring.generate(["source"]).problem(payload, decode(payload)) == "bad signature"
    assert ring.problem(encode(_eos()), _eos()) == "unsigned"
    with pytest.raises(ValueError, match="not an aamtrack-keyring-1 keyring"):
        Keyring.from_bytes(b'{"keys": {}}')
    with pytest.raises(ValueError, match="is not 32 bytes"):
        Keyring({"source": b"short"})


def test_a_frame_is_signed_over_its_pixels_where_they_lie() -> None:
    """The producer hashes the pixels once where they lie and hands them on uncopied: the
    parts join into the payload :func:`encode_signed` makes, the last part is the buffer the
    frame's array views; the signature is the key's of the digest, and of no other digest."""
    buffer = bytearray(24 * 32 * 3)
    image = np.frombuffer(buffer, np.uint8).reshape(24, 32, 3)
    image[...] = np.arange(image.size, dtype=np.uint8).reshape(image.shape)
    frame = _frame(image)
    parts = encode_signed_parts(KEY, frame)
    assert parts[-1] is buffer
    payload = b"".join(parts)
    assert payload == encode_signed(KEY, frame)
    signed = decode(payload, "frame")
    assert is_signed(KEY, payload, signed)
    unsigned = encode_parts(frame)
    assert unsigned[-1] is buffer and b"".join(unsigned) == encode(frame)
    head = msgpack.packb(signed.header.to_dict("frame") | {"auth": ""})
    body = payload[payload.index(b"\xa4body") + 5:]
    assert verifies(KEY, digest(head, body), signed.header.auth)
    assert sign_digest(KEY, digest(head, body)) == signed.header.auth
    assert not verifies(KEY, digest(head, body[:-1] + b"\x00"), signed.header.auth)
    assert not verifies(bytes(KEY_BYTES), digest(head, body), signed.header.auth)
