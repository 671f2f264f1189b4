"""Tests of the Zenoh key expressions and name validation."""

from __future__ import annotations

import pytest
import zenoh

from proto import keys
from proto.limits import ProtoError
from proto.messages import MESSAGE_TYPES


def test_keys_of_a_stream() -> None:
    assert keys.topic_key("cam0", "fit") == "aamtrack/cam0/fit"
    assert keys.status_key("cam0", "fitter") == "aamtrack/cam0/status/fitter"
    assert keys.detect_key("cam0") == "aamtrack/cam0/detect"
    assert keys.alive_key("cam0", "pose") == "aamtrack/cam0/alive/pose"
    assert keys.stream_wildcard("cam0") == "aamtrack/cam0/**"
    assert keys.status_wildcard() == "aamtrack/*/status/*"
    assert keys.alive_wildcard("cam0") == "aamtrack/cam0/alive/*"
    assert keys.topic_wildcard("frame") == "aamtrack/*/frame"


def test_every_message_kind_has_a_key() -> None:
    assert set(keys.TOPICS) | {keys.STATUS} == set(MESSAGE_TYPES)


@pytest.mark.parametrize(
    "name", ["a/b", "a*", "$x", "a#", "a?b", "", "-x", ".x", "x" * 65, "a b", "é", "a@b", "**"]
)
def test_unsafe_names_are_rejected(name: str) -> None:
    with pytest.raises(ProtoError, match="stream id"):
        keys.topic_key(name, "fit")
    with pytest.raises(ProtoError, match="service"):
        keys.status_key("cam0", name)


def test_non_string_names_and_unknown_topics_are_rejected() -> None:
    with pytest.raises(ProtoError, match="expected a string, got int"):
        keys.check_name(3)
    with pytest.raises(ProtoError, match="no per-stream key"):
        keys.topic_key("cam0", "status")


@pytest.mark.parametrize("name", ["cam0", "Cam_1", "lab.cam-2", "_", "x" * 64])
def test_safe_names_make_canonical_zenoh_keys(name: str) -> None:
    for key in (keys.topic_key(name, "frame"), keys.status_key(name, name)):
        assert str(zenoh.KeyExpr(key)) == key
        assert zenoh.KeyExpr(keys.stream_wildcard(name)).includes(zenoh.KeyExpr(key))


def test_wildcards_match_their_keys() -> None:
    everything = zenoh.KeyExpr(keys.stream_wildcard("cam0"))
    for topic in keys.TOPICS:
        assert everything.includes(zenoh.KeyExpr(keys.topic_key("cam0", topic)))
        assert zenoh.KeyExpr(keys.topic_wildcard(topic)).includes(
            zenoh.KeyExpr(keys.topic_key("cam9", topic))
        )
    assert not everything.includes(zenoh.KeyExpr(keys.topic_key("cam1", "fit")))
    assert zenoh.KeyExpr(keys.status_wildcard("cam0")).includes(
        zenoh.KeyExpr(keys.status_key("cam0", "fitter"))
    )


def test_parse_key_inverts_the_builders() -> None:
    assert keys.parse_key(keys.topic_key("cam0", "fit")) == ("cam0", "fit", None)
    assert keys.parse_key(keys.detect_key("cam0")) == ("cam0", "detect", None)
    assert keys.parse_key(keys.status_key("cam0", "pose")) == ("cam0", "status", "pose")
    assert keys.parse_key(keys.alive_key("c", "p")) == ("c", "alive", "p")
    for bad in [
        "aamtrack/cam0",
        "other/cam0/fit",
        "aamtrack/cam0/nope",
        "aamtrack/cam0/fit/x",
        "aamtrack/cam0/status",
        "aamtrack/c*/fit",
    ]:
        with pytest.raises(ProtoError):
            keys.parse_key(bad)
