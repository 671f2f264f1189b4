"""``aamtrack router``: a real router process relays between two client sessions."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

from services.cli.router_cmd import DEFAULT_LISTEN, router_config
from services.stack.launcher import free_port
from tests.deploy.conftest import (
    REPO_ROOT,
    ZENOH_DIR,
    Probe,
    RouterProcess,
    child_env,
    client_config,
    publish_until_received,
)


def test_two_clients_exchange_messages_only_through_the_router(
    start_router: Callable[..., RouterProcess],
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = start_router(["--listen", endpoint])
    assert endpoint in router.banner
    # Client mode: neither session listens, so the only path between them is the router.
    sub = Probe(client_config("client", endpoint), "aamtrack/t/**")
    pub = Probe(client_config("client", endpoint))
    try:
        assert publish_until_received(pub.session, "aamtrack/t/fit", sub, b"hello")
        assert pub.received == []
    finally:
        pub.close()
        sub.close()
    out = router.stop()
    assert router.proc.returncode == 0 and "router stopped" in out, out


def test_router_reads_the_deploy_config_and_command_line_endpoints_win(
    start_router: Callable[..., RouterProcess],
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = start_router(["--config", str(ZENOH_DIR / "router.json5"), "--listen", endpoint])
    assert router.banner.strip().endswith(f"listening on {endpoint}"), router.banner
    sub = Probe(client_config("client", endpoint), "aamtrack/t/**")
    pub = Probe(client_config("peer", endpoint, listen="tcp/127.0.0.1:0"))
    try:
        assert publish_until_received(pub.session, "aamtrack/t/pose", sub, b"via-config")
    finally:
        pub.close()
        sub.close()


def test_router_config_defaults_to_the_loopback_endpoint() -> None:
    cfg = router_config(None, [], [])
    assert DEFAULT_LISTEN in cfg.get_json("listen/endpoints")
    assert cfg.get_json("mode") == '"router"'


def test_router_with_a_missing_config_file_exits_2_naming_it(tmp_path: Path) -> None:
    missing = tmp_path / "nope.json5"
    done = subprocess.run([sys.executable, "-m", "services", "router", "--config", str(missing)],
                          capture_output=True, text=True, timeout=60, cwd=REPO_ROOT,
                          env=child_env())
    assert done.returncode == 2
    assert f"zenoh config {missing}: no such file" in done.stderr


def test_router_with_a_busy_port_exits_1_with_a_message(
    start_router: Callable[..., RouterProcess],
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    start_router(["--listen", endpoint])
    done = subprocess.run([sys.executable, "-m", "services", "router", "--listen", endpoint],
                          capture_output=True, text=True, timeout=60, cwd=REPO_ROOT,
                          env=child_env())
    assert done.returncode == 1, done.stdout + done.stderr
    assert "cannot open the router" in done.stderr
