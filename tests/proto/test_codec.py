"""Tests of encode/decode: every kind of bad payload is rejected with a precise reason."""

from __future__ import annotations

import struct

import msgpack
import numpy as np
import pytest

from proto.codec import decode, encode, payload_limit
from proto.header import SCHEMA_VERSION, Header
from proto.limits import (
    MAX_DIM,
    MAX_IMAGE_PAYLOAD,
    MAX_INT,
    MAX_LIST_LEN,
    MAX_SMALL_PAYLOAD,
    MAX_STR_LEN,
    ProtoError,
)
from proto.messages import (
    MESSAGE_TYPES,
    EndOfStream,
    Expression,
    FaceBoxes,
    Fit,
    FitAppearance,
    Frame,
    Message,
    Status,
)


def unpack(payload: bytes) -> dict:
    return msgpack.unpackb(payload, raw=False)


def pack(obj: object) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


def reason_of(payload: bytes, expected_kind: str | None = None) -> str:
    with pytest.raises(ProtoError) as info:
        decode(payload, expected_kind)
    assert info.value.reason
    return info.value.reason


def fit_with(golden: dict[str, Message], **body: object) -> bytes:
    obj = unpack(encode(golden["fit"]))
    appearance = {k: body.pop(k) for k in list(body) if k in obj["body"]["appearance"]}
    obj["body"]["appearance"].update(appearance)
    obj["body"].update(body)
    return pack(obj)


def test_every_strict_prefix_of_every_golden_payload_is_rejected(
    golden: dict[str, Message],
) -> None:
    for kind, msg in golden.items():
        payload = encode(msg)
        for cut in range(len(payload)):
            reason = reason_of(payload[:cut], None if cut % 2 else kind)
            assert "empty" in reason or "incomplete" in reason or "not valid msgpack" in reason


def test_trailing_bytes_are_rejected(golden: dict[str, Message]) -> None:
    assert "extra" in reason_of(encode(golden["eos"]) + b"\x00").lower()


@pytest.mark.parametrize(
    ("body", "reason"),
    [
        ({"iterations": "7"}, "fit.appearance.iterations: expected an integer, got str"),
        ({"iterations": 7.0}, "fit.appearance.iterations: expected an integer, got float"),
        ({"converged": 1}, "fit.appearance.converged: expected a boolean, got int"),
        ({"scheme": b"ibug68"}, "fit.scheme: expected a string, got bytes"),
        ({"texture_error": None},
         "fit.appearance.texture_error: expected a number, got NoneType"),
        ({"landmarks": [[1.0, 2.0]]}, "fit.landmarks: expected an array map, got list"),
        ({"warp_path": "tpu"}, "fit.warp_path: 'tpu' is not one of ['gpu', 'cpu', 'none']"),
        ({"appearance": [1]}, "fit.appearance: expected a map, got list"),
    ],
)
def test_wrong_types_are_named(golden: dict[str, Message], body: dict, reason: str) -> None:
    assert reason_of(fit_with(golden, **body)) == reason


def test_missing_and_unknown_fields_are_named(golden: dict[str, Message]) -> None:
    obj = unpack(encode(golden["fit"]))
    del obj["body"]["similarity"]
    assert reason_of(pack(obj)) == "fit: missing field 'similarity'"
    obj = unpack(encode(golden["fit"]))
    obj["body"]["extra"] = 1
    assert reason_of(pack(obj)) == "fit: unknown field 'extra'"
    obj = unpack(encode(golden["fit"]))
    del obj["body"]["appearance"]["occluded"]
    assert reason_of(pack(obj)) == "fit.appearance: missing field 'occluded'"
    obj = unpack(encode(golden["fit"]))
    del obj["header"]["producer"]
    assert reason_of(pack(obj)) == "header: missing field 'producer'"
    assert reason_of(pack({"header": obj["header"]})) == "message: missing field 'body'"
    assert reason_of(pack({"body": {}})) == "message: missing field 'header'"
    assert reason_of(pack([1, 2])) == "message: expected a map, got list"
    assert reason_of(pack({1: 2})).startswith("payload is not valid msgpack")


def test_shape_and_byte_length_mismatch_is_named(golden: dict[str, Message]) -> None:
    obj = unpack(encode(golden["fit"]))
    obj["body"]["landmarks"]["shape"] = [67, 2]
    assert (
        reason_of(pack(obj))
        == "fit.landmarks: data has 544 bytes but shape [67, 2] of f4 needs 536"
    )


@pytest.mark.parametrize("dtype", ["i8", "f2", "<f4", "O", "u1"])
def test_disallowed_or_wrong_dtypes_are_named(golden: dict[str, Message], dtype: str) -> None:
    obj = unpack(encode(golden["fit"]))
    obj["body"]["landmarks"]["dtype"] = dtype
    reason = reason_of(pack(obj))
    assert reason.startswith("fit.landmarks: dtype ") and repr(dtype) in reason
    assert ("allow-list" in reason) != (dtype == "u1")


@pytest.mark.parametrize("version", [SCHEMA_VERSION - 1, SCHEMA_VERSION + 1, 2**40])
def test_other_schema_versions_are_rejected_naming_both(
    golden: dict[str, Message], version: int
) -> None:
    obj = unpack(encode(golden["pose"]))
    obj["header"]["schema_version"] = version
    obj["body"] = {"a future": "layout"}
    reason = reason_of(pack(obj))
    assert f"schema version {version} " in reason
    assert f"only version {SCHEMA_VERSION}" in reason


def test_kind_is_checked(golden: dict[str, Message]) -> None:
    assert reason_of(encode(golden["fit"]), "pose") == "header.kind: expected 'pose', got 'fit'"
    obj = unpack(encode(golden["fit"]))
    obj["header"]["kind"] = "gaze"
    assert reason_of(pack(obj)).startswith("header.kind: 'gaze' is not one of")
    assert reason_of(b"\xc0", "gaze").startswith("expected kind 'gaze' is not one of")


@pytest.mark.parametrize(
    ("declared", "what"),
    [
        (b"\xc6" + struct.pack(">I", 0xFFFFFFFF), "bin"),
        (b"\xdb" + struct.pack(">I", 0xFFFFFFFF), "str"),
        (b"\xdd" + struct.pack(">I", 0xFFFFFFFF), "array"),
        (b"\xdf" + struct.pack(">I", 0xFFFFFFFF), "map"),
        (b"\xc9" + struct.pack(">I", 0xFFFFFFFF) + b"\x01", "ext"),
    ],
)
def test_huge_declared_msgpack_sizes_are_rejected(declared: bytes, what: str) -> None:
    reason = reason_of(b"\x82\xa6header" + declared + b"\x00" * 16)
    assert reason.startswith("payload is not valid msgpack")


def test_huge_declared_array_shapes_are_rejected(golden: dict[str, Message]) -> None:
    obj = unpack(encode(golden["frame"]))
    obj["body"]["image"]["shape"] = [4096, 4096, 3]
    assert "exceed the limit" in reason_of(pack(obj))
    obj["body"]["image"]["shape"] = [2**62, 2**62, 3]
    assert "free dimensions at most 4096" in reason_of(pack(obj))


def test_oversized_payloads_are_rejected_before_unpacking(golden: dict[str, Message]) -> None:
    big = bytes(MAX_SMALL_PAYLOAD + 1)
    assert (
        reason_of(big, "fit")
        == f"payload of {len(big)} bytes exceeds the limit of {MAX_SMALL_PAYLOAD}"
    )
    assert "exceeds the limit" in reason_of(bytes(MAX_IMAGE_PAYLOAD + 1))
    obj = unpack(encode(golden["eos"]))
    obj["body"]["reason"] = "x" * 1000
    obj["header"]["padding"] = b"\x00" * MAX_SMALL_PAYLOAD
    assert reason_of(pack(obj)).startswith(f"eos: payload of {len(pack(obj))} bytes exceeds")


def test_oversized_images_are_refused_by_the_constructor() -> None:
    header = Header("cam0", 0, 0, "capture", 0)
    with pytest.raises(ProtoError, match="frame.image: 50331648 bytes exceed the limit"):
        Frame.from_array(header, np.zeros((4096, 4096, 3), np.uint8))


def largest_messages() -> list[Message]:
    """The biggest message of each size-limited kind that the field limits allow."""
    header = Header("c" * 64, MAX_INT, MAX_INT, "p" * 64, MAX_INT, "r" * 64)
    text = "é" * (MAX_STR_LEN // 2)
    side = np.zeros(MAX_DIM, np.float32)
    names = [f"{i:04d}" + "x" * (MAX_STR_LEN - 4) for i in range(MAX_LIST_LEN)]
    return [
        Frame.from_array(header, np.zeros((2160, 4096, 3), np.uint8)),
        FaceBoxes(header, 4096, 4096, np.zeros((MAX_DIM, 4)), side),
        Fit(
            header, text, np.zeros((MAX_DIM, 2)), np.ones(4), 4096, 4096, True, text, 1.0, "cpu",
            FitAppearance(side, np.zeros((128, 512)), 1.0, MAX_INT, True,
                          np.ones(MAX_DIM, np.uint8)),
        ),
        Expression(header, names[0], names, np.full(MAX_LIST_LEN, 1 / MAX_LIST_LEN),
                   smoothed=True, reason=""),
        Expression(header, "", names, np.zeros(0), smoothed=True, reason=text),
        Status(header, "s" * 64, "running", *[MAX_INT] * 7, 1.0, 1.0, MAX_INT, text),
        EndOfStream(header, MAX_INT, text),
    ]


def test_the_largest_valid_messages_fit_their_payload_limits() -> None:
    for msg in largest_messages():
        payload = encode(msg)
        assert len(payload) <= payload_limit(msg.KIND), msg.KIND
        assert decode(payload, msg.KIND) == msg


def test_non_bytes_payloads_are_rejected() -> None:
    assert reason_of("text") == "payload must be bytes, got str"  # type: ignore[arg-type]
    assert reason_of(None) == "payload must be bytes, got NoneType"  # type: ignore[arg-type]


def test_bytearray_and_memoryview_payloads_decode(golden: dict[str, Message]) -> None:
    payload = encode(golden["fit"])
    assert decode(bytearray(payload)) == golden["fit"]
    assert decode(memoryview(payload), "fit") == golden["fit"]


def test_payload_limits() -> None:
    assert payload_limit("frame") == payload_limit("overlay") == payload_limit(None)
    assert all(
        payload_limit(k) == MAX_SMALL_PAYLOAD
        for k in MESSAGE_TYPES
        if k not in ("frame", "overlay")
    )


def test_a_raw_frame_decodes_to_a_view_of_its_payload_in_any_layout() -> None:
    """The pixels of a frame laid out as the encoder lays it out are read where they lie in
    the payload (each subscriber would otherwise copy them); another valid layout decodes to
    the same message through the general path, copied."""
    image = np.arange(12 * 16 * 3, dtype=np.uint8).reshape(12, 16, 3)
    frame = Frame.from_array(Header.now("cam0", 7, "source"), image)
    payload = encode(frame)
    fast = decode(payload, "frame")
    assert fast == frame and not fast.image.flags.writeable
    assert np.shares_memory(fast.image, np.frombuffer(payload, np.uint8))
    obj = msgpack.unpackb(payload)
    body = obj["body"]
    obj["body"] = {"image": body["image"], **{k: v for k, v in body.items() if k != "image"}}
    other = msgpack.packb(obj, use_bin_type=True)  # the image first: another encoder's layout
    slow = decode(other, "frame")
    assert slow == frame and not np.shares_memory(slow.image, np.frombuffer(other, np.uint8))
