"""A reader's trust in a run: the run's public keys, fetched from its launcher.

The launcher answers ``aamtrack/<stream>/keys`` with the run's public keys signed by its own
key (:func:`proto.auth.keys_document`). A reader (``aamtrack echo``, ``record``, the Rerun
logger started on its own, any program) asks every queryable on that key and takes the
answer whose launcher key has the fingerprint it trusts (``--trust``, printed by ``aamtrack
run`` and written beside its summary). Without one it takes the only launcher that
answers, and says that nothing anchored it; two launchers with different keys (a forged run
beside the real one) are refused until ``--trust`` says which.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from proto.auth import RunKeys, read_keys_document
from proto.keys import keys_key

ASK_EVERY = 1.0
"""Seconds each ask waits for answers (a reader started before the run asks again)."""


class RunKeysError(RuntimeError):
    """No run's keys can be trusted: none answered, or not the trusted one, or several."""


def _answers(session: Any, stream: str, trust: str, wait: float
             ) -> tuple[dict[str, RunKeys], list[str]]:
    import zenoh

    found: dict[str, RunKeys] = {}
    problems: list[str] = []
    replies = session.get(keys_key(stream), target=zenoh.QueryTarget.ALL,
                          consolidation=zenoh.ConsolidationMode.NONE, timeout=wait)
    for reply in replies:
        if reply.ok is None:
            continue
        try:
            keys = read_keys_document(reply.ok.payload.to_bytes(), trust)
        except ValueError as exc:
            problems.append(str(exc))
            continue
        if keys.stream != stream:
            problems.append(f"keys of stream {keys.stream!r}")
            continue
        known = found.get(keys.fingerprint)
        if known is None or (keys.run_id and not known.run_id):  # the source host's run
            found[keys.fingerprint] = keys
        if trust:
            break  # the trusted launcher answered: nobody else's answer matters
    return found, problems


def fetch_run_keys(session: Any, stream: str, trust: str = "", timeout: float = 10.0,
                   stopped: Callable[[float], bool] | None = None) -> RunKeys:
    """The public keys of the run on ``stream`` whose launcher ``trust`` names (any single
    one without it), asked for until one answers or ``timeout`` s have passed.

    Raises
    ------
    RunKeysError
        When no launcher (or not the trusted one) answered, or several with different
        keys answered and no ``trust`` says which.
    """
    deadline = time.monotonic() + timeout
    problems: list[str] = []
    while True:
        wait = max(0.1, min(ASK_EVERY, deadline - time.monotonic()))
        found, problems = _answers(session, stream, trust, wait)
        if len(found) > 1:
            raise RunKeysError(
                f"{len(found)} launchers with different keys answer for stream {stream!r} "
                f"({', '.join(found)}): give --trust with the fingerprint aamtrack run "
                "printed")
        if found:
            return next(iter(found.values()))
        if time.monotonic() >= deadline or (stopped is not None and stopped(0.05)):
            break
    said = f" ({'; '.join(sorted(set(problems))[:3])})" if problems else ""
    whose = f"the launcher {trust} trusts" if trust else "a launcher"
    raise RunKeysError(f"no run's keys on stream {stream!r} from {whose} within "
                       f"{timeout:g} s{said}: is aamtrack run running there?")
