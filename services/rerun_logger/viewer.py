"""Rerun viewer URLs: read one as the Rerun CLI does, and check that a viewer listens there.

A viewer (``rerun``, or ``rerun --serve-grpc`` on a server) listens for
logging SDKs on ``rerun+http://HOST:PORT/proxy``. Rerun's SDK connects
lazily and never reports a viewer that is not there (it buffers, then drops
the data), so the service and the launcher try the viewer's TCP port before
anything streams, and say so in one line when nothing answers.

This module does not import ``rerun``: the launcher's preflight checks use it.
"""

from __future__ import annotations

import socket
from dataclasses import dataclass
from urllib.parse import urlsplit

DEFAULT_PORT = 9876
"""Where ``rerun`` listens for SDKs unless told otherwise."""
DEFAULT_URL = f"rerun+http://127.0.0.1:{DEFAULT_PORT}/proxy"
"""The viewer ``--connect`` without a value streams to (Rerun's own default)."""
SCHEME_PORTS = {"rerun+http": DEFAULT_PORT, "rerun+https": 443, "rerun": 443}
"""Schemes Rerun accepts, and the port each implies (as Rerun reads them)."""
PROBE_TIMEOUT_S = 2.0


class ViewerError(ValueError):
    """A viewer URL that cannot be read, or where no viewer answers; one line."""


@dataclass(frozen=True)
class ViewerAddress:
    """Where a viewer listens: its URL (as Rerun takes it), host and port."""

    url: str
    host: str
    port: int


def viewer_address(text: str) -> ViewerAddress:
    """Read a viewer URL, or a bare port (``9876`` is ``rerun+http://127.0.0.1:9876/proxy``).

    Raises
    ------
    ViewerError
        For a scheme other than ``rerun://``, ``rerun+http://`` or
        ``rerun+https://``, a path other than ``/proxy``, no host, or a port
        outside 1 to 65535.
    """
    text = text.strip()
    if text.isdigit():
        text = f"rerun+http://127.0.0.1:{int(text)}/proxy"
    expected = "expected rerun+http://HOST:PORT/proxy or a port"
    parts = urlsplit(text)
    if parts.scheme not in SCHEME_PORTS:
        raise ViewerError(f"{text!r}: {expected}")
    if parts.path.rstrip("/") != "/proxy":
        raise ViewerError(f"{text!r}: the path must be /proxy ({expected})")
    try:
        port = parts.port
    except ValueError:
        raise ViewerError(f"{text!r}: the port must be a number from 1 to 65535") from None
    if not parts.hostname:
        raise ViewerError(f"{text!r}: no host ({expected})")
    if port == 0:
        raise ViewerError(f"{text!r}: the port must be a number from 1 to 65535")
    return ViewerAddress(text, parts.hostname, port or SCHEME_PORTS[parts.scheme])


def viewer_url_problem(value: object) -> str:
    """An option check: what is wrong with a viewer URL, or ``""``."""
    if value is None:
        return ""
    try:
        viewer_address(str(value))
    except ViewerError as exc:
        return str(exc).split(": ", 1)[-1]
    return ""


def check_viewer(text: str, timeout: float = PROBE_TIMEOUT_S) -> ViewerAddress:
    """The viewer's address, once something accepts a connection on its port.

    Raises
    ------
    ViewerError
        When the URL cannot be read, or nothing listens there (one line,
        saying how to start a viewer).
    """
    address = viewer_address(text)
    try:
        with socket.create_connection((address.host, address.port), timeout=timeout):
            pass
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        if isinstance(exc, TimeoutError | socket.timeout):
            why = f"no answer within {timeout:g} s"
        raise ViewerError(
            f"no Rerun viewer at {address.url} ({why.lower()}): start one with "
            f"`rerun --port {address.port}`, or give the URL of one that runs") from None
    return address
