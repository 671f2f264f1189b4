"""Tests of the scalar field specs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from proto.fields import Bool, Float, Int, Str, StrList, check_keys
from proto.limits import MAX_INT, ProtoError


def test_int_accepts_numpy_ints_and_rejects_bools_floats_and_out_of_range() -> None:
    spec = Int(0, 10)
    assert spec.check(np.int64(3), "n") == 3 and type(spec.check(np.int64(3), "n")) is int
    for bad, reason in [(True, "got bool"), (3.0, "got float"), (11, "outside"), (-1, "outside")]:
        with pytest.raises(ProtoError, match=f"^n: .*{reason}"):
            spec.check(bad, "n")
    with pytest.raises(ProtoError, match="outside"):
        Int().check(MAX_INT + 1, "n")


def test_float_takes_ints_and_rejects_nan_inf_and_range() -> None:
    spec = Float(0.0, 1.0)
    assert spec.check(1, "f") == 1.0 and type(spec.check(np.float32(0.5), "f")) is float
    for bad, reason in [
        (math.nan, "NaN"),
        (math.inf, "infinity"),
        (2.0, "outside"),
        (False, "bool"),
    ]:
        with pytest.raises(ProtoError, match=reason):
            spec.check(bad, "f")
    assert math.isnan(Float(allow_nan=True).check(math.nan, "f"))
    with pytest.raises(ProtoError, match="infinity is not allowed"):
        Float(allow_nan=True).check(-math.inf, "f")
    with pytest.raises(ProtoError, match="too large"):
        Float().check(10**400, "f")


def test_bool_rejects_integers() -> None:
    assert Bool().check(np.True_, "b") is True
    with pytest.raises(ProtoError, match="expected a boolean, got int"):
        Bool().check(1, "b")


def test_str_limits_choices_and_validation() -> None:
    assert Str(choices=("a", "b")).check("a", "s") == "a"
    with pytest.raises(ProtoError, match=r"'c' is not one of \['a', 'b'\]"):
        Str(choices=("a", "b")).check("c", "s")
    with pytest.raises(ProtoError, match=r"3 bytes is outside \[0, 2\]"):
        Str(max_len=2).check("é!", "s")
    with pytest.raises(ProtoError, match=r"outside \[1, "):
        Str(min_len=1).check("", "s")
    with pytest.raises(ProtoError, match="not valid UTF-8"):
        Str().check("\ud800", "s")
    with pytest.raises(ProtoError, match="got bytes"):
        Str().check(b"a", "s")


def test_str_list_is_a_tuple_of_distinct_non_empty_strings() -> None:
    spec = StrList(max_items=3)
    assert spec.check(["a", "b"], "l") == ("a", "b")
    assert spec.encode(("a", "b")) == ["a", "b"]
    for bad, reason in [
        (["a", "a"], "distinct"),
        (["a", ""], r"l\[1\]"),
        (["a", 1], r"l\[1\]: expected a string"),
        (["a"] * 4, "4 items exceed 3"),
        ("ab", "expected a list"),
    ]:
        with pytest.raises(ProtoError, match=reason):
            spec.check(bad, "l")


def test_check_keys_names_missing_and_unknown_fields() -> None:
    assert check_keys({"a": 1, "b": 2}, ("a", "b"), "m") == {"a": 1, "b": 2}
    with pytest.raises(ProtoError, match="m: missing field 'b'"):
        check_keys({"a": 1}, ("a", "b"), "m")
    with pytest.raises(ProtoError, match="m: unknown field 'c'"):
        check_keys({"a": 1, "b": 2, "c": 3}, ("a", "b"), "m")
    with pytest.raises(ProtoError, match="m: unknown field b'c'"):
        check_keys({"a": 1, b"c": 3}, ("a",), "m")
    with pytest.raises(ProtoError, match="m: expected a map, got list"):
        check_keys([], ("a",), "m")
