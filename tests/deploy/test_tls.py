"""TLS and mutual TLS with the deploy configuration files and certificates made here.

The router runs ``deploy/zenoh/router-tls.json5`` unchanged (its ``certs/...``
paths resolve in the test's PKI folder); clients load
``deploy/zenoh/client-tls.json5``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import zenoh

from proto.zenoh_config import config_from_file
from services.stack.launcher import free_port
from tests.deploy.conftest import (
    ZENOH_DIR,
    Probe,
    RouterProcess,
    publish_until_received,
    wait_until,
)


def tls_client(endpoint: str, identity: str | None, ca: str = "certs/ca.pem") -> Any:
    """``client-tls.json5`` connecting to ``endpoint`` as ``certs/<identity>`` (none: no
    client certificate at all)."""
    cfg = config_from_file(ZENOH_DIR / "client-tls.json5", connect=[endpoint])
    cfg.insert_json5("transport/link/tls/root_ca_certificate", json.dumps(ca))
    if identity is None:
        cfg.insert_json5("transport/link/tls/enable_mtls", "false")
        cfg.insert_json5("transport/link/tls/connect_certificate", "null")
        cfg.insert_json5("transport/link/tls/connect_private_key", "null")
    else:
        cfg.insert_json5(
            "transport/link/tls/connect_certificate", json.dumps(f"certs/{identity}.pem")
        )
        cfg.insert_json5(
            "transport/link/tls/connect_private_key", json.dumps(f"certs/{identity}.key")
        )
    return cfg


@pytest.fixture
def tls_router(
    pki: Path, start_router: Callable[..., RouterProcess], monkeypatch: pytest.MonkeyPatch
) -> Callable[[bool], str]:
    """``tls_router(mtls)``: a router on ``router-tls.json5`` (mutual TLS on or off); its
    endpoint. The test's working directory becomes the PKI folder."""
    monkeypatch.chdir(pki)

    def start(mtls: bool) -> str:
        config = pki / "router.json5"
        text = (ZENOH_DIR / "router-tls.json5").read_text()
        assert "enable_mtls: true" in text
        config.write_text(text if mtls else text.replace("enable_mtls: true", "enable_mtls: false"))
        port = free_port()
        start_router(["--config", str(config), "--listen", f"tls/127.0.0.1:{port}"], cwd=pki)
        return f"tls/localhost:{port}"

    return start


def test_mutual_tls_client_with_a_stack_certificate_gets_messages_through(
    tls_router: Callable[[bool], str],
) -> None:
    endpoint = tls_router(True)
    sub = Probe(tls_client(endpoint, "stack"), "aamtrack/cam0/**")
    pub = Probe(tls_client(endpoint, "stack"))
    try:
        assert publish_until_received(pub.session, "aamtrack/cam0/fit", sub, b"tls")
    finally:
        pub.close()
        sub.close()


@pytest.mark.parametrize("identity", [None, "impostor"])
def test_mutual_tls_refuses_a_client_without_a_certificate_of_the_stack_ca(
    tls_router: Callable[[bool], str],
    identity: str | None,
) -> None:
    endpoint = tls_router(True)
    # impostor: common name aamtrack-impostor, signed by another CA which it trusts itself.
    ca = "certs/ca.pem" if identity is None else "certs/other-ca.pem"
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        zenoh.open(tls_client(endpoint, identity, ca=ca))


def test_a_peer_without_a_client_certificate_opens_but_exchanges_nothing(
    tls_router: Callable[[bool], str],
) -> None:
    endpoint = tls_router(True)
    sub = Probe(tls_client(endpoint, "stack"), "aamtrack/cam0/**")
    cfg = tls_client(endpoint, None)
    cfg.insert_json5("mode", '"peer"')  # a peer opens even when its connect target refuses it
    outsider = Probe(cfg)
    try:
        assert not publish_until_received(
            outsider.session, "aamtrack/cam0/fit", sub, b"x", timeout=2.0
        )
    finally:
        outsider.close()
        sub.close()


def test_tls_without_mutual_auth_accepts_a_client_without_certificate(
    tls_router: Callable[[bool], str],
) -> None:
    endpoint = tls_router(False)
    sub = Probe(tls_client(endpoint, "stack"), "aamtrack/cam0/**")
    anonymous = Probe(tls_client(endpoint, None))
    try:
        assert publish_until_received(anonymous.session, "aamtrack/cam0/fit", sub, b"anon")
    finally:
        anonymous.close()
        sub.close()


def test_a_client_that_does_not_trust_the_router_certificate_cannot_connect(
    tls_router: Callable[[bool], str],
) -> None:
    endpoint = tls_router(False)
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        zenoh.open(tls_client(endpoint, None, ca="certs/other-ca.pem"))


def test_a_service_runs_over_mutual_tls_from_the_deploy_file(
    tls_router: Callable[[bool], str], pki: Path
) -> None:
    """``--zenoh-config deploy/zenoh/client-tls.json5``: a real service's status gets through."""
    from proto.codec import decode
    from proto.keys import status_key
    from services.bus.connection import BusOptions
    from services.bus.options import options_argv
    from services.bus.session import Service

    endpoint = tls_router(True)
    config = pki / "service-client.json5"
    config.write_text((ZENOH_DIR / "client-tls.json5").read_text())
    bus = BusOptions(mode="client", connect=(endpoint,), zenoh_config=str(config))
    assert "--zenoh-config" in options_argv(bus)
    probe = Probe(tls_client(endpoint, "stack"), status_key("cam0", "tlsprobe"))
    try:
        with Service("tlsprobe", bus, status_period=0.2, handle_signals=False) as svc:
            svc.ready("over TLS")
            got = wait_until(lambda: bool(probe.received), 8.0)
        assert got, "no status message came through the TLS router"
        assert decode(probe.received[0]).service == "tlsprobe"
    finally:
        probe.close()
