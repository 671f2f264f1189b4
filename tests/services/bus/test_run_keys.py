"""services.bus.run_keys: a reader takes the run's public keys from the launcher it trusts,
and refuses to choose between two launchers with different keys."""

from __future__ import annotations

import pytest

from proto.auth import Keyring, keys_document
from proto.keys import keys_key
from services.bus.connection import BusOptions
from services.bus.run_keys import RunKeysError, fetch_run_keys
from services.bus.session import Service


def test_the_trusted_launcher_s_keys_and_none_when_two_launchers_answer(
    bus_pair: tuple[BusOptions, BusOptions],
) -> None:
    real, forged = (Keyring.generate(["launcher", "pose"]) for _ in range(2))
    stream = bus_pair[0].stream
    with Service("launcher", bus_pair[0], handle_signals=False, announce=False) as host:
        for ring in (real, forged):  # one session answers for both: both always answer
            doc = keys_document(ring, stream, "run-1")
            host.queryable(keys_key(stream), lambda q, d=doc: q.reply(q.key_expr, d))
        with Service("reader", bus_pair[1], handle_signals=False, announce=False) as reader:
            keys = fetch_run_keys(reader.session, stream, real.fingerprint, timeout=30)
            assert keys.keyring == real.public_only() and keys.run_id == "run-1"
            with pytest.raises(RunKeysError, match="2 launchers with different keys"):
                fetch_run_keys(reader.session, stream, timeout=30)
            with pytest.raises(RunKeysError, match="no run's keys on stream"):
                fetch_run_keys(reader.session, stream, "ab" * 16, timeout=1)
