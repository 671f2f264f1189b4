"""Tests of the message header and the schema version check."""

from __future__ import annotations

import time

import pytest

from proto.header import SCHEMA_VERSION, WIRE_KEYS, Header, read_kind
from proto.limits import ProtoError


def test_now_stamps_publish_and_default_capture_time() -> None:
    before = time.time_ns()
    header = Header.now("cam0", 5, "capture")
    assert before <= header.publish_time_ns <= time.time_ns()
    assert header.capture_time_ns == header.publish_time_ns
    assert Header.now("cam0", 5, "capture", capture_time_ns=7).capture_time_ns == 7


def test_wire_form_puts_version_and_kind_first_and_round_trips() -> None:
    header = Header("cam0", 1, 2, "fitter", 3)
    wire = header.to_dict("fit")
    assert tuple(wire) == WIRE_KEYS
    assert wire["schema_version"] == SCHEMA_VERSION and wire["kind"] == "fit"
    assert read_kind(wire) == "fit"
    assert Header.from_dict(wire) == header


@pytest.mark.parametrize(
    ("args", "reason"),
    [
        (("cam/0", 1, 2, "p", 3), "header.stream_id"),
        (("cam0", -1, 2, "p", 3), "header.frame_index: -1 is outside"),
        (("cam0", 1, 2.0, "p", 3), "header.capture_time_ns: expected an integer, got float"),
        (("cam0", 1, 2, "a*", 3), "header.producer"),
        (("cam0", 1, 2, "p", 2**63), "header.publish_time_ns"),
        (("cam0", True, 2, "p", 3), "header.frame_index: expected an integer, got bool"),
    ],
)
def test_bad_header_fields_are_named(args: tuple, reason: str) -> None:
    with pytest.raises(ProtoError, match=reason):
        Header(*args)


@pytest.mark.parametrize("version", [0, SCHEMA_VERSION + 1, -3])
def test_other_schema_versions_are_rejected_naming_both(version: int) -> None:
    wire = Header("cam0", 1, 2, "p", 3).to_dict("fit") | {"schema_version": version}
    with pytest.raises(ProtoError) as info:
        read_kind(wire)
    assert f"schema version {version} " in info.value.reason
    assert f"reads only version {SCHEMA_VERSION}" in info.value.reason
    assert ("newer" if version > SCHEMA_VERSION else "older") in info.value.reason


def test_read_kind_rejects_missing_and_mistyped_version_and_kind() -> None:
    wire = Header("cam0", 1, 2, "p", 3).to_dict("fit")
    cases = [
        (
            {k: v for k, v in wire.items() if k != "schema_version"},
            "missing field 'schema_version'",
        ),
        ({k: v for k, v in wire.items() if k != "kind"}, "missing field 'kind'"),
        (wire | {"schema_version": "1"}, "schema_version: expected an integer, got str"),
        (wire | {"schema_version": True}, "got bool"),
        (wire | {"kind": 1}, "header.kind: expected a string, got int"),
        ([1], "header: expected a map, got list"),
    ]
    for obj, reason in cases:
        with pytest.raises(ProtoError, match=reason):
            read_kind(obj)


def test_from_dict_rejects_extra_header_fields() -> None:
    wire = Header("cam0", 1, 2, "p", 3).to_dict("fit") | {"host": "x"}
    with pytest.raises(ProtoError, match="header: unknown field 'host'"):
        Header.from_dict(wire)
