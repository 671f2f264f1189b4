"""Where a single-host run's processes meet: Unix sockets in a folder only its user can open.

A run on one host (``aamtrack run`` without ``--endpoint``) listens on no network port:
the launcher and each service listen on a Unix socket in :func:`runtime_dir`, a folder
of mode 0700 owned by the user (``$XDG_RUNTIME_DIR/aamtrack``, else
``/tmp/aamtrack-<uid>``), so that no other user's process can connect, read a frame or
publish into the run. Zenoh's shared-memory segments are the user's alone as well
(mode 0600). ``aamtrack echo`` and ``record`` connect to the stream's socket there by
default.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import stat
from pathlib import Path

from services.bus.options import OptionError

SCHEME = "unixsock-stream/"


def runtime_dir() -> Path:
    """The user's private folder for the sockets of single-host runs, made if needed.

    Raises
    ------
    OptionError
        When the folder exists but another user owns it or others may open it (someone
        could listen in): it is never used then.
    """
    base = os.environ.get("XDG_RUNTIME_DIR", "")
    folder = (Path(base) / "aamtrack" if base and Path(base).is_dir()
              else Path("/tmp") / f"aamtrack-{os.getuid()}")
    with contextlib.suppress(FileExistsError):
        folder.mkdir(mode=0o700, parents=False)
    info = folder.lstat()
    if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid():
        raise OptionError(f"{folder}: not a folder of this user: the stack will not put its "
                          "sockets there (remove it, or give --endpoint)")
    if info.st_mode & 0o077:
        raise OptionError(f"{folder}: other users may open it (mode "
                          f"{stat.S_IMODE(info.st_mode):o}): chmod 700 it, or give --endpoint")
    return folder


def socket_endpoint(path: Path) -> str:
    """The Zenoh endpoint of the Unix socket ``path``."""
    return f"{SCHEME}{path}"


def socket_path(endpoint: str) -> Path | None:
    """The socket file of a Unix-socket endpoint; None for any other endpoint."""
    return Path(endpoint[len(SCHEME):]) if endpoint.startswith(SCHEME) else None


def stream_endpoint(stream: str) -> str:
    """Where a run of ``stream`` listens by default, and ``echo`` and ``record`` connect."""
    return socket_endpoint(runtime_dir() / f"{stream}.sock")


def in_use(path: Path) -> bool:
    """Whether a live process listens on the socket ``path`` (Zenoh holds a lock on
    ``<path>.lock`` while it does; a socket left by a killed process is free)."""
    lock = Path(f"{path}.lock")
    if not lock.exists():
        return False
    try:
        with open(lock, "a") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            fcntl.flock(handle, fcntl.LOCK_UN)
    except BlockingIOError:
        return True
    except OSError:
        return True  # a lock we cannot even open is not ours to take
    return False


def remove_socket(endpoint: str) -> None:
    """Remove a Unix socket endpoint's files once nobody listens on it."""
    path = socket_path(endpoint)
    if path is None or in_use(path):
        return
    for leftover in (path, Path(f"{path}.lock")):
        with contextlib.suppress(OSError):
            leftover.unlink()
