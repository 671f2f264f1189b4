"""The documentation's examples state the contract the code speaks: every schema version they
give and the header keys they show, read from proto/README.md and README.md (whoever changes
the header or the version updates both, or this fails)."""

from __future__ import annotations

import re

import msgpack

from aamcore.config import REPO_ROOT
from proto.header import SCHEMA_VERSION, WIRE_KEYS

PROTO_README = (REPO_ROOT / "proto" / "README.md").read_text(encoding="utf-8")
README = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
NUMBERS = {"eight": 8, "nine": 9, "ten": 10, "eleven": 11, "twelve": 12, "thirteen": 13,
           "fourteen": 14}


def _versions(text: str, pattern: str) -> list[int]:
    found = [int(v) for v in re.findall(pattern, text)]
    assert found, f"no {pattern!r} in the documentation"
    return found


def test_every_schema_version_the_docs_give_is_the_code_s() -> None:
    stated = (_versions(PROTO_README, r"version of this contract: \*\*(\d+)\*\*")
              + _versions(PROTO_README, r"`header\.schema_version` is an integer equal\s+to (\d+)")
              + _versions(PROTO_README, r"`SCHEMA_VERSION = (\d+)`")
              + _versions(PROTO_README, r"this decoder reads only version (\d+)")
              + _versions(PROTO_README, r"schema_version\"?\]? ?== ?(\d+)")
              + _versions(README, r"contract version (\d+)"))
    assert set(stated) == {SCHEMA_VERSION}, stated


def _worked_example() -> bytes:
    block = PROTO_README.split("annotated (`tests/proto/golden/eos.msgpack`):")[1]
    block = block.split("```hex\n")[1].split("```")[0]
    return bytes.fromhex(" ".join(line.split("#")[0] for line in block.splitlines()))


def test_the_worked_example_is_the_golden_message_with_the_header_s_keys() -> None:
    payload = _worked_example()
    assert payload == (REPO_ROOT / "tests" / "proto" / "golden" / "eos.msgpack").read_bytes()
    header = msgpack.unpackb(payload)["header"]
    assert tuple(header) == WIRE_KEYS and header["schema_version"] == SCHEMA_VERSION
    count = re.search(r'# "header"\n[0-9a-f ]+# map of (\d+)', PROTO_README)
    assert count and int(count.group(1)) == len(WIRE_KEYS)


def test_the_decoding_rules_count_the_header_s_keys() -> None:
    (word,) = re.findall(r"The header has exactly its (\w+) keys", PROTO_README)
    assert NUMBERS[word] == len(WIRE_KEYS)
