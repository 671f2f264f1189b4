"""Fixtures of the message-contract tests: the golden messages and their files."""

from __future__ import annotations

from pathlib import Path

import pytest

from proto.golden import golden_messages
from proto.messages import Message

GOLDEN_DIR = Path(__file__).parent / "golden"


@pytest.fixture(scope="session")
def golden() -> dict[str, Message]:
    """One canonical message per kind, keyed by kind."""
    return golden_messages()


@pytest.fixture(scope="session")
def golden_files() -> dict[str, bytes]:
    """The committed golden payloads, keyed by kind."""
    return {path.stem: path.read_bytes() for path in sorted(GOLDEN_DIR.glob("*.msgpack"))}
