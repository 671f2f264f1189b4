"""The Rerun logging service's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from services.bus.options import Options, in_range, option

DEFAULT_QUALITY = 85


@dataclass(frozen=True)
class RerunOptions(Options):
    """Where the recording goes and when the service stops."""

    rrd: str | None = option(None, "write the recording to this file", metavar="PATH")
    serve: int | None = option(None, "serve the recording over gRPC on 127.0.0.1:PORT",
                               metavar="PORT", check=in_range(1, 65535))
    linger: float = option(0.0, "with --serve: keep serving S seconds after the stream ends",
                           metavar="S", check=in_range(0))
    jpeg_quality: int = option(DEFAULT_QUALITY, "JPEG quality for raw frames and overlays",
                               metavar="Q", check=in_range(1, 100))
    head_model: bool = option(True, "draw the 3D head model with the pose")
    idle: float = option(1.0, "after end of stream, stop once nothing arrived for S seconds",
                         metavar="S", check=in_range(0))
    grace: float = option(10.0, "after end of stream, stop after S seconds at most",
                          metavar="S", check=in_range(0))
