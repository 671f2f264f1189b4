"""``aamtrack router`` and ``aamtrack keys``: what a deployment over several hosts needs
beside the stack.

``aamtrack keys FILE`` writes a new keys file (mode 600): a secret key per service
(:mod:`proto.auth`), which every host of a stack file names in ``[bus] keys`` and gets a
copy of, as it gets its certificates.

``aamtrack router``: a Zenoh router where ``zenohd`` is not installed.

It opens one Zenoh session in router mode, listening on the given endpoints
(and optionally connecting to other routers), from a configuration file
(``deploy/zenoh/router.json5``, ``router-tls.json5``...) or from the command
line, and keeps it open until SIGINT or SIGTERM. Once the session is open it
prints one line, ``router <zid> listening on <endpoints>``, so that scripts
and tests can wait for it.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from types import FrameType
from typing import Any

from proto.zenoh_config import config_from_file, zenoh_config
from services.cli.commands import add_command

DEFAULT_LISTEN = "tcp/127.0.0.1:7447"
"""Where the router listens when neither ``--listen`` nor a config file says."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``router`` and ``keys``."""
    k = add_command(
        subparsers, "keys",
        description="Write a key pair for every service (and the launchers) to a new file "
        "of mode 600. Name it in the stack file ([bus] keys = FILE) and copy it to every "
        "host: each service signs what it publishes with its key, and checks what it "
        "receives with the others'.")
    k.add_argument("file", metavar="FILE", help="the keys file to write (never overwritten)")
    k.set_defaults(func=cmd_keys)
    p = add_command(
        subparsers, "router",
        description="Open a Zenoh session in router mode and keep it open until SIGINT or "
        "SIGTERM. Endpoints given here replace those of the config file.")
    p.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                   help=f"endpoint to listen on, repeatable (default {DEFAULT_LISTEN}, or the "
                   "config file's)")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="another router to connect to, repeatable")
    p.add_argument("--config", metavar="FILE",
                   help="Zenoh JSON5 configuration file (TLS, access control, ...)")
    p.set_defaults(func=cmd_router)


def cmd_keys(args: argparse.Namespace) -> int:
    """``aamtrack keys FILE``: 0 once written, 2 when the file exists or cannot be made."""
    from proto.auth import Keyring
    from services.bus.trust import write_keys_file
    from services.stack.registry import SERVICES

    keyring = Keyring.generate([*SERVICES, "launcher"])
    try:
        write_keys_file(args.file, keyring)
    except OSError as exc:
        print(f"aamtrack keys: error: {args.file}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.file}: key pairs of {', '.join([*SERVICES, 'launcher'])}; launcher "
          f"key {keyring.fingerprint} (readers: --trust {keyring.fingerprint}); copy it to "
          "every host (mode 600, owned by the user the stack runs as, alone)")
    return 0


def router_config(config: str | None, listen: list[str], connect: list[str]) -> Any:
    """The router's ``zenoh.Config``: the file's (if any) with mode ``router`` and the
    endpoints given here.

    Raises
    ------
    FileNotFoundError, ValueError
        For a missing or malformed file or a malformed endpoint.
    """
    if config is not None:
        cfg = config_from_file(config, "router", listen, connect)
        if not json.loads(cfg.get_json("listen/endpoints") or "[]"):
            cfg.insert_json5("listen/endpoints", json.dumps([DEFAULT_LISTEN]))
        return cfg
    return zenoh_config("router", listen or [DEFAULT_LISTEN], connect)


def _listening(cfg: Any) -> list[str]:
    endpoints = json.loads(cfg.get_json("listen/endpoints") or "[]")
    if isinstance(endpoints, dict):  # per-mode form: {"router": [...], "peer": [...]}
        endpoints = endpoints.get("router", [])
    return [str(e) for e in endpoints]


def cmd_router(args: argparse.Namespace) -> int:
    """``aamtrack router``: serve until SIGINT or SIGTERM; 0 then."""
    import zenoh

    zenoh.init_log_from_env_or("error")
    cfg = router_config(args.config, args.listen, args.connect)
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        try:
            session = zenoh.open(cfg)
        except zenoh.ZError as exc:
            print(f"aamtrack router: error: cannot open the router: {exc}", file=sys.stderr)
            return 1
        try:
            print(f"router {session.zid()} listening on {', '.join(_listening(cfg))}",
                  flush=True)
            while not stop.wait(0.2):
                pass
        finally:
            session.close()
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    print("router stopped", flush=True)
    return 0
