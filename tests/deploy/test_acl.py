"""Access control under the secure configuration (``deploy/zenoh/router-acl.json5``).

Every client holds a certificate of the stack's CA, so all of them connect;
the router's access rules decide by certificate common name who may publish
on ``aamtrack/**``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from services.stack.launcher import free_port
from tests.deploy.conftest import (
    ZENOH_DIR,
    Probe,
    RouterProcess,
    publish_until_received,
    wait_until,
)
from tests.deploy.test_tls import tls_client

KEY = "aamtrack/cam0/fit"


def _router(pki: Path, start_router: Callable[..., RouterProcess], config: str) -> str:
    port = free_port()
    start_router(["--config", str(ZENOH_DIR / config), "--listen", f"tls/127.0.0.1:{port}"],
                 cwd=pki)
    return f"tls/localhost:{port}"


@pytest.fixture
def acl_endpoint(pki: Path, start_router: Callable[..., RouterProcess],
                 monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.chdir(pki)
    return _router(pki, start_router, "router-acl.json5")


@pytest.fixture
def stack_subscriber(acl_endpoint: str) -> Iterator[Probe]:
    probe = Probe(tls_client(acl_endpoint, "stack"), "aamtrack/**")
    yield probe
    probe.close()


def test_the_stack_identity_publishes_and_an_outsider_is_refused(
    acl_endpoint: str, stack_subscriber: Probe,
) -> None:
    stack = Probe(tls_client(acl_endpoint, "stack"))
    rogue = Probe(tls_client(acl_endpoint, "rogue"))
    try:
        # The allowed publisher gets through: the subscription has reached the router.
        assert publish_until_received(stack.session, KEY, stack_subscriber, b"stack")
        for n in range(40):
            rogue.session.put(KEY, b"rogue%d" % n)
            stack.session.put(KEY, b"after%d" % n)
        # Each refused put came before an allowed one: all of them had their chance.
        assert wait_until(lambda: b"after39" in stack_subscriber.received, 60.0)
        assert not any(r.startswith(b"rogue") for r in stack_subscriber.received)
    finally:
        rogue.close()
        stack.close()


def test_the_stack_cannot_publish_outside_its_keys(
    acl_endpoint: str, stack_subscriber: Probe,
) -> None:
    other = Probe(tls_client(acl_endpoint, "stack"), "elsewhere/**")
    control = other.session.declare_subscriber(KEY, other._on)  # the same session, allowed
    stack = Probe(tls_client(acl_endpoint, "stack"))
    try:
        assert publish_until_received(stack.session, KEY, other, b"in", timeout=60.0)
        for n in range(20):
            stack.session.put("elsewhere/x", b"out%d" % n)
        # The positive control: a later put of the same session through the same router to
        # the same subscriber's session arrives, so the earlier ones had their chance.
        assert publish_until_received(stack.session, KEY, other, b"after", timeout=60.0)
        assert not any(r.startswith(b"out") for r in other.received)
    finally:
        control.undeclare()
        stack.close()
        other.close()


def test_a_viewer_receives_the_stack_messages_but_cannot_publish(
    acl_endpoint: str, stack_subscriber: Probe,
) -> None:
    viewer = Probe(tls_client(acl_endpoint, "viewer"), "aamtrack/**")
    stack = Probe(tls_client(acl_endpoint, "stack"))
    queried: list[str] = []
    ping = stack_subscriber.session.declare_queryable(  # on the subscriber's own session
        "aamtrack/cam0/ping", lambda query: queried.append(str(query.key_expr)))
    try:
        assert publish_until_received(stack.session, KEY, viewer, b"to-viewer", timeout=60.0)
        for n in range(20):
            viewer.session.put(KEY, b"viewer%d" % n)
        # The positive control: a query the viewer may send, after its puts on the same
        # session, reaches the subscriber's session through the same router, so the puts
        # before it had their chance.
        def ping_arrived() -> bool:
            viewer.session.get("aamtrack/cam0/ping", timeout=1.0)
            return wait_until(lambda: bool(queried), 0.2)

        assert wait_until(ping_arrived, 60.0), "no query of the viewer arrived"
        assert not any(r.startswith(b"viewer") for r in stack_subscriber.received)
    finally:
        ping.undeclare()
        stack.close()
        viewer.close()


def test_control_without_access_control_the_same_outsider_gets_through(
    pki: Path, start_router: Callable[..., RouterProcess], monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The refusals above come from the access rules, not from TLS: same certificates,
    router-tls.json5 (no access control), and the outsider's puts arrive, on the stack's
    keys and outside them."""
    monkeypatch.chdir(pki)
    endpoint = _router(pki, start_router, "router-tls.json5")
    sub = Probe(tls_client(endpoint, "stack"), "aamtrack/**")
    other = Probe(tls_client(endpoint, "stack"), "elsewhere/**")
    rogue = Probe(tls_client(endpoint, "rogue"))
    try:
        assert publish_until_received(rogue.session, KEY, sub, b"rogue", timeout=60.0)
        assert publish_until_received(rogue.session, "elsewhere/x", other, b"out", timeout=60.0)
    finally:
        rogue.close()
        other.close()
        sub.close()
