"""proto/README.md's tables say what the code does: keys, owners, QoS and fields."""

from __future__ import annotations

import re

import pytest

from aamcore.config import REPO_ROOT
from proto.header import WIRE_KEYS
from proto.keys import OWNERS, TOPICS
from proto.messages import MESSAGE_TYPES
from services.bus.qos import MUST_ARRIVE, TOPIC_QOS, QoS

README = (REPO_ROOT / "proto" / "README.md").read_text(encoding="utf-8")


def _rows(section: str) -> list[list[str]]:
    """The body rows of the first table after the heading line ``section``."""
    start = README.index(section + "\n")
    rows: list[list[str]] = []
    for line in README[start:].splitlines()[1:]:
        if line.startswith("|"):
            rows.append([cell.strip() for cell in line.strip("|").split(" | ")])
        elif rows:
            break
    assert rows[1][0].startswith("---"), f"no table after {section}"
    return rows[2:]


def _qos(row: list[str]) -> QoS:
    congestion, priority, express = row[3:6]
    assert express in ("yes", "no"), row
    return QoS(congestion, priority, express == "yes")


KEY_ROWS = _rows("## 1. Zenoh keys, owners and QoS")


def _key_rows(topic: str) -> list[list[str]]:
    return [row for row in KEY_ROWS if row[0] == f"`aamtrack/<stream>/{topic}`"]


@pytest.mark.parametrize("kind", TOPICS)
def test_each_topic_has_its_owner_and_qos(kind: str) -> None:
    (row,) = _key_rows(kind)
    assert row[1].startswith(f"`{kind}`")
    assert row[2] == f"`{OWNERS[kind]}`"
    assert _qos(row) == TOPIC_QOS[kind]


def test_status_periodic_and_final_qos() -> None:
    periodic, final = _key_rows("status/<service>")
    assert periodic[2] == final[2] == "`<service>`"
    assert "final" in final[1] and _qos(final) == MUST_ARRIVE
    assert _qos(periodic) == TOPIC_QOS["status"]


def test_detect_and_alive_rows() -> None:
    (detect,) = _key_rows("detect")
    assert _qos(detect) == TOPIC_QOS["fit"]  # the querier's (services.bus.receiving)
    (alive,) = _key_rows("alive/<service>")
    assert "liveliness" in alive[1]
    assert len(KEY_ROWS) == len(TOPICS) + 4


def test_header_table_lists_the_wire_keys() -> None:
    assert [row[0] for row in _rows("## 3. Header")] == [f"`{k}`" for k in WIRE_KEYS]


@pytest.mark.parametrize("kind", [k for k in MESSAGE_TYPES if k != "overlay"])
def test_each_kind_table_lists_its_fields(kind: str) -> None:
    heading = next(line for line in README.splitlines() if re.match(rf"### `{kind}`: ", line))
    keys = [row[0] for row in _rows(heading)]
    assert keys == [f"`{name}`" for name in MESSAGE_TYPES[kind].specs()]
