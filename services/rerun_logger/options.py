"""The Rerun logging service's options (see :mod:`services.bus.options`).

The recording goes to any of three places: a file (``--rrd``, alias
``--save``), a gRPC server of its own that viewers connect to (``--serve
PORT``), or a viewer that already runs (``--viewer [URL]``; ``aamtrack run``
offers it as ``--connect [URL]``, the service's ``--connect`` being its Zenoh
endpoint).
"""

from __future__ import annotations

from dataclasses import dataclass

from services.bus.options import Options, in_range, option
from services.rerun_logger.viewer import DEFAULT_URL, viewer_url_problem

DEFAULT_QUALITY = 85


@dataclass(frozen=True)
class RerunOptions(Options):
    """Where the recording goes and when the service stops."""

    rrd: str | None = option(None, "write the recording to this file", metavar="PATH",
                             aliases=("--save",))
    serve: int | None = option(None, "serve the recording over gRPC on 127.0.0.1:PORT; after "
                               "the end of stream it goes on serving until interrupted",
                               metavar="PORT", check=in_range(1, 65535))
    viewer: str | None = option(None, "stream the recording to a running Rerun viewer at URL "
                                "(rerun+http://HOST:PORT/proxy, or a port)", metavar="URL",
                                const=DEFAULT_URL, check=viewer_url_problem)
    linger: float | None = option(None, "with --serve: after the end of stream, stop after S "
                                  "seconds (default: serve until interrupted)", metavar="S",
                                  check=in_range(0))
    jpeg_quality: int = option(DEFAULT_QUALITY, "JPEG quality for raw frames and overlays",
                               metavar="Q", check=in_range(1, 100))
    head_model: bool = option(True, "draw the 3D head model with the pose")
    glasses: bool = option(True, "draw the AR glasses on the 3D head")
    idle: float = option(1.0, "after end of stream, stop once nothing arrived for S seconds",
                         metavar="S", check=in_range(0))
    grace: float = option(10.0, "after end of stream, stop after S seconds at most",
                          metavar="S", check=in_range(0))
    unverified: bool = option(False, "started on its own: log every well-formed message, "
                              "checking no signature (a stack without keys); said in the "
                              "recording")

    @property
    def has_output(self) -> bool:
        """Whether the recording goes anywhere (a file, a server or a viewer)."""
        return self.rrd is not None or self.serve is not None or self.viewer is not None
