"""Tests of the array codec: wire maps, the dtype allow-list, shapes, sizes, NaN."""

from __future__ import annotations

import numpy as np
import pytest

from proto.arrays import DTYPES, ArraySpec
from proto.limits import MAX_DIM, ProtoError

POINTS = ArraySpec("f4", (None, 2), 4096)
POINTS_NAN = ArraySpec("f4", (None, 2), 4096, allow_nan=True)


def wire(arr: np.ndarray, spec: ArraySpec = POINTS) -> dict:
    """The wire map as msgpack would unpack it (``data`` as bytes)."""
    obj = spec.encode(spec.check(arr, "x"))
    return obj | {"data": bytes(obj["data"])}


def test_round_trip_keeps_values_shape_and_dtype() -> None:
    arr = np.array([[1.5, -2.25], [3.0, 4.125], [0.0, 1e-3]])
    out = POINTS.decode(wire(arr), "x")
    assert out.dtype == np.dtype("<f4")
    assert out.shape == (3, 2)
    np.testing.assert_array_equal(out, arr.astype(np.float32))
    assert not out.flags.writeable


def test_encoding_is_little_endian_row_major() -> None:
    obj = wire(np.array([[1.0, 2.0]]))
    assert obj == {"dtype": "f4", "shape": [1, 2], "data": bytes.fromhex("0000803f00000040")}


def test_check_casts_big_endian_and_non_contiguous_input() -> None:
    arr = np.arange(8, dtype=">f8").reshape(2, 4)[:, ::2]
    out = POINTS.check(arr, "x")
    assert out.dtype == np.dtype("<f4") and out.flags.c_contiguous
    np.testing.assert_array_equal(out, [[0, 2], [4, 6]])


def test_empty_array_round_trips() -> None:
    assert POINTS.decode(wire(np.zeros((0, 2))), "x").shape == (0, 2)


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ({"dtype": "i8"}, "not in the allow-list"),
        ({"dtype": "<f4"}, "not in the allow-list"),
        ({"dtype": "f8"}, "dtype must be 'f4'"),
        ({"dtype": 4}, "dtype must be a string"),
        ({"shape": [3]}, "list of 2 ints, got list of 1"),
        ({"shape": "3,2"}, "got str"),
        ({"shape": [3, 3]}, "does not match (*, 2)"),
        ({"shape": [-1, 2]}, "does not match"),
        ({"shape": [MAX_DIM + 1, 2]}, f"free dimensions at most {MAX_DIM}"),
        ({"shape": [3.0, 2]}, "shape must hold integers, got ['float', 'int']"),
        ({"shape": [True, 2]}, "shape must hold integers"),
        ({"shape": [4, 2]}, "data has 24 bytes but shape [4, 2] of f4 needs 32"),
        ({"data": b"\x00" * 23}, "data has 23 bytes"),
        ({"data": "abc"}, "data must be binary, got str"),
    ],
)
def test_decode_rejects_with_reason(change: dict, reason: str) -> None:
    obj = wire(np.ones((3, 2))) | change
    with pytest.raises(ProtoError, match="^x: ") as info:
        POINTS.decode(obj, "x")
    assert reason in info.value.reason


def test_decode_rejects_missing_and_extra_keys_and_non_maps() -> None:
    obj = wire(np.ones((3, 2)))
    for bad in ({k: v for k, v in obj.items() if k != "data"}, obj | {"order": "C"}, [1, 2], b"x"):
        with pytest.raises(ProtoError, match="^x: "):
            POINTS.decode(bad, "x")


def test_huge_declared_shape_is_rejected_before_allocation() -> None:
    spec = ArraySpec("u1", (None, None, 3), 100)
    obj = {"dtype": "u1", "shape": [MAX_DIM, MAX_DIM, 3], "data": b""}
    with pytest.raises(ProtoError, match="exceed the limit of 100"):
        spec.decode(obj, "x")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_are_rejected_unless_nan_is_allowed(bad: float) -> None:
    arr = np.array([[1.0, bad]])
    obj = {"dtype": "f4", "shape": [1, 2], "data": arr.astype("<f4").tobytes()}
    with pytest.raises(ProtoError, match="1 NaN or infinite element"):
        POINTS.decode(obj, "x")
    with pytest.raises(ProtoError, match="NaN or infinite"):
        POINTS.check(arr, "x")
    if np.isnan(bad):
        assert np.isnan(POINTS_NAN.decode(obj, "x")[0, 1])
    else:
        with pytest.raises(ProtoError, match="1 infinite element"):
            POINTS_NAN.decode(obj, "x")


def test_u1_fields_refuse_to_cast() -> None:
    spec = ArraySpec("u1", (None, None), 1000)
    with pytest.raises(
        ProtoError, match="expected a uint8 numpy array, got array of dtype float64"
    ):
        spec.check(np.zeros((2, 2)), "img")
    with pytest.raises(ProtoError, match="got list"):
        spec.check([[1, 2]], "img")


def test_float_fields_refuse_non_numbers() -> None:
    with pytest.raises(ProtoError, match="expected real numbers"):
        POINTS.check(np.array([["a", "b"]]), "x")
    with pytest.raises(ProtoError, match="expected real numbers"):
        POINTS.check(np.array([[True, False]]), "x")


def test_allow_list_is_little_endian() -> None:
    assert all(d.byteorder in ("<", "|", "=") for d in DTYPES.values())
    assert [d.str for d in DTYPES.values()] == ["|u1", "<f4", "<f8"]
