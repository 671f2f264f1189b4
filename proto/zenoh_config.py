"""A Zenoh configuration that works in sandboxes and on real networks alike.

Multicast scouting is off by default: peers find each other only through the
explicit ``listen`` and ``connect`` endpoints, which is what works reliably in
containers (see STACK_NOTES). A peer whose ``connect`` target is not up yet
still opens and keeps retrying.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # imported where a configuration is built, not by the options that name one
    import zenoh

MODES = ("peer", "client", "router")
DROP_WAIT_US = {"wait_before_drop": 30_000, "max_wait_before_drop_fragments": 200_000}
"""How long a droppable message waits for room in a link's queue before it is dropped,
microseconds. Zenoh's defaults (1 ms; 50 ms for the fragments of a large message such as a
frame) dropped a frame or a fit now and then on a loaded machine with nothing stuck: the
two-core stack test (tests/services/stack/test_parity.py) lost one in 20 runs beside three
busy processes, none in 24 with these waits (and none in 52 with longer ones). A consumer
that really stops still loses messages, after these waits."""
_ENDPOINT = re.compile(r"(tcp|udp|tls|quic|unixsock-stream|ws)/\S+")


def zenoh_config(
    mode: str = "peer",
    listen: Sequence[str] = (),
    connect: Sequence[str] = (),
    multicast_scouting: bool = False,
) -> zenoh.Config:
    """Build a ``zenoh.Config``.

    Parameters
    ----------
    mode : str
        ``"peer"``, ``"client"`` or ``"router"``.
    listen, connect : sequence of str
        Endpoints such as ``"tcp/127.0.0.1:7447"``.
    multicast_scouting : bool
        Whether to discover peers by UDP multicast as well.

    Raises
    ------
    ValueError
        For an unknown mode or an endpoint that is not ``<protocol>/<address>``.
    """
    if mode not in MODES:
        raise ValueError(f"zenoh mode {mode!r} is not one of {list(MODES)}")
    for endpoint in (*listen, *connect):
        if not isinstance(endpoint, str) or _ENDPOINT.fullmatch(endpoint) is None:
            raise ValueError(f"zenoh endpoint {endpoint!r} is not like 'tcp/127.0.0.1:7447'")
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    config.insert_json5("scouting/multicast/enabled", json.dumps(multicast_scouting))
    for key, value in DROP_WAIT_US.items():
        config.insert_json5(f"transport/link/tx/queue/congestion_control/drop/{key}",
                            json.dumps(value))
    return config


def config_from_file(
    path: str | Path,
    mode: str | None = None,
    listen: Sequence[str] = (),
    connect: Sequence[str] = (),
) -> zenoh.Config:
    """Load a Zenoh JSON5 configuration file, overriding its mode and endpoints if given.

    The files under ``deploy/zenoh/`` are such files (TLS, access control...);
    relative certificate paths in them are resolved by Zenoh against the
    working directory.

    Parameters
    ----------
    path : str or Path
        A ``.json5`` file in Zenoh's configuration format.
    mode : str, optional
        Replaces the file's ``mode`` when given.
    listen, connect : sequence of str
        Replace the file's ``listen/endpoints`` or ``connect/endpoints`` when not empty.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        For a file Zenoh cannot parse, an unknown mode or a malformed endpoint.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"zenoh config {path}: no such file")
    if mode is not None and mode not in MODES:
        raise ValueError(f"zenoh mode {mode!r} is not one of {list(MODES)}")
    for endpoint in (*listen, *connect):
        if not isinstance(endpoint, str) or _ENDPOINT.fullmatch(endpoint) is None:
            raise ValueError(f"zenoh endpoint {endpoint!r} is not like 'tcp/127.0.0.1:7447'")
    import zenoh

    try:
        config = zenoh.Config.from_file(str(path))
    except zenoh.ZError as exc:
        raise ValueError(f"zenoh config {path}: {exc}") from None
    if mode is not None:
        config.insert_json5("mode", json.dumps(mode))
    if listen:
        config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    if connect:
        config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    return config
