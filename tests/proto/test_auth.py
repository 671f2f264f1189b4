"""proto.auth: every message signed by its producer's private key (Ed25519 over the message's
digest), over the header and the body as it travels, and checked with its public key alone;
nothing else passes for it. The launcher's signed document of a run's public keys."""

from __future__ import annotations

from dataclasses import replace

import msgpack
import numpy as np
import pytest

from proto import EndOfStream, Frame, Header, decode, encode
from proto.auth import (
    KEY_BYTES,
    Keyring,
    encode_signed,
    encode_signed_parts,
    fingerprint,
    is_signed,
    keys_document,
    message_digest,
    public_key,
    read_keys_document,
    sign,
    verify,
)
from proto.codec import encode_parts
from proto.limits import ProtoError

KEY = bytes(range(KEY_BYTES))
PUBLIC = public_key(KEY)
DIGEST = "51421c8dfbaed077943c9d2f87b4f55b843708eaafb8d32872471f9ca5d8ca25"
SIGNATURE = ("b245d78f8877675727e86920a3b2febc1a6477fd9ca3405d2d42fd3df2dc0cef"
             "2fafd1ee369b74117604f0e04295a6be43f8edab607632524816f2a8c6297b09")


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
    assert len(eos.header.auth) == 128 and is_signed(PUBLIC, payload, eos)
    assert replace(eos, header=replace(eos.header, auth="")) == _eos()
    assert payload == encode(eos)  # laid out as the codec lays out any message
    # Test vectors for other implementations: the digest, and Ed25519's deterministic
    # signature of it (RFC 8032) by the private key 00 01 .. 1f.
    digest = message_digest(msgpack.packb(_eos().header.to_dict("eos")),
                            msgpack.packb(_eos().to_dict(), use_bin_type=True))
    assert digest.hex() == DIGEST
    assert eos.header.auth == sign(KEY, digest).hex() == SIGNATURE
    assert verify(PUBLIC, digest, bytes.fromhex(SIGNATURE))
    assert not verify(PUBLIC, bytes(32), bytes.fromhex(SIGNATURE))


def test_the_signature_covers_the_pixels_their_shape_and_channels() -> None:
    image = np.arange(24 * 32 * 3, dtype=np.uint8).reshape(24, 32, 3)
    payload = encode_signed(KEY, _frame(image))
    frame = decode(payload, "frame")
    assert is_signed(PUBLIC, payload, frame)
    auth = frame.header.auth

    def resigned_header_on(other: Frame) -> bytes:
        """``other`` with the signed frame's header (and signature): the replay of issue 37."""
        return encode(replace(other, header=replace(other.header, auth=auth)))

    black = image.copy()
    black[5, 7, 1] ^= 1  # one bit of one pixel
    for other in (_frame(black), _frame(image.reshape(48, 16, 3)),
                  _frame(np.ascontiguousarray(image[:, :, 0]))):
        forged = resigned_header_on(other)
        assert not is_signed(PUBLIC, forged, decode(forged, "frame"))


def test_another_key_a_cut_signature_or_a_changed_header_does_not_pass() -> None:
    payload = encode_signed(KEY, _eos())
    eos = decode(payload, "eos")
    assert not is_signed(public_key(bytes(KEY_BYTES)), payload, eos)  # another run's key
    unsigned = encode(_eos())
    assert not is_signed(PUBLIC, unsigned, decode(unsigned))
    for changed in (replace(eos, total_frames=1),
                    replace(eos, header=replace(eos.header, frame_index=0)),
                    replace(eos, header=replace(eos.header, producer="fitter"))):
        forged = encode(changed)
        assert not is_signed(PUBLIC, forged, decode(forged))
    with pytest.raises(ProtoError, match="header.auth: expected empty or 128 lower-case hex"):
        replace(eos.header, auth=eos.header.auth[:127])  # a truncated signature is malformed


def test_a_header_re_encoded_otherwise_does_not_pass() -> None:
    """The header must be the canonical encoding: the bytes hashed are the bytes read."""
    payload = encode_signed(KEY, _eos())
    obj = msgpack.unpackb(payload)
    obj["header"] = dict(reversed(list(obj["header"].items())))  # same fields, other order
    obj["header"] = {"schema_version": obj["header"].pop("schema_version"),
                     "kind": obj["header"].pop("kind")} | obj["header"]
    other = msgpack.packb(obj)
    assert other != payload
    assert not is_signed(PUBLIC, other, decode(other))


def test_a_keyring_gives_each_service_its_own_key_and_every_public_one() -> None:
    ring = Keyring.generate(["source", "fitter", "pose"])
    pose = ring.for_service("pose")
    assert pose.signer == "pose" and set(pose.secrets) == {"pose"}
    assert set(pose.public) == {"source", "fitter", "pose"}
    assert Keyring.from_bytes(pose.to_bytes()) == pose
    source = ring.for_service("source")
    payload = source.encode(_eos())
    reader = ring.public_only()  # no secret at all
    assert not reader.secrets and reader.problem(payload, decode(payload)) == ""
    assert Keyring(ring.public_only().public | {"source": PUBLIC}).problem(
        payload, decode(payload)) == "bad signature"
    assert Keyring({"fitter": ring.public["fitter"]}).problem(
        payload, decode(payload)) == "not a service of the run"
    assert ring.problem(encode(_eos()), _eos()) == "unsigned"
    with pytest.raises(ValueError, match="not an aamtrack-keyring-2 keyring"):
        Keyring.from_bytes(b'{"public": {}}')
    with pytest.raises(ValueError, match="is not 32 bytes"):
        Keyring({"source": b"short"})
    with pytest.raises(ValueError, match="not its public key's"):
        Keyring({"source": PUBLIC}, {"source": bytes(KEY_BYTES)})


def test_a_run_s_keys_document_is_its_launcher_s_and_trusted_by_its_fingerprint() -> None:
    ring = Keyring.generate(["source", "fitter", "launcher"])
    document = keys_document(ring, "cam0", "run-1")
    keys = read_keys_document(document)
    assert keys.keyring == ring.public_only() and (keys.stream, keys.run_id) == ("cam0", "run-1")
    assert keys.fingerprint == fingerprint(ring.public["launcher"]) == ring.fingerprint
    assert read_keys_document(document, ring.fingerprint[:16]).keyring == keys.keyring
    forger = Keyring.generate(["source", "fitter", "launcher"])  # a forged run's own keys
    forged = keys_document(forger, "cam0", "run-1")
    assert read_keys_document(forged).fingerprint != ring.fingerprint
    with pytest.raises(ValueError, match="is not the trusted"):
        read_keys_document(forged, ring.fingerprint)
    # The real launcher's signature over another run's public keys does not pass.
    swapped = msgpack.unpackb(forged)
    swapped["signature"] = msgpack.unpackb(document)["signature"]
    with pytest.raises(ValueError, match="not signed by its launcher"):
        read_keys_document(msgpack.packb(swapped))
    with pytest.raises(ValueError, match="not a run's keys"):
        read_keys_document(b"\x01garbage")


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
    assert is_signed(PUBLIC, payload, signed)
    unsigned = encode_parts(frame)
    assert unsigned[-1] is buffer and b"".join(unsigned) == encode(frame)
    head = msgpack.packb(signed.header.to_dict("frame") | {"auth": ""})
    body = payload[payload.index(b"\xa4body") + 5:]
    signature = bytes.fromhex(signed.header.auth)
    assert verify(PUBLIC, message_digest(head, body), signature)
    assert sign(KEY, message_digest(head, body)) == signature
    assert not verify(PUBLIC, message_digest(head, body[:-1] + b"\x00"), signature)
    assert not verify(public_key(bytes(KEY_BYTES)), message_digest(head, body), signature)
