"""The source's options (see :mod:`services.bus.options`)."""

from __future__ import annotations

from dataclasses import dataclass

from services.bus.options import OptionError, Options, in_range, option
from services.bus.shm import POOL_IMAGES

PACES = ("realtime", "fast")
URL_PREFIXES = ("rtsp://", "rtsps://", "http://", "https://", "udp://", "tcp://", "rtmp://")


def _url_problem(url: str | None) -> str:
    if url is not None and not url.startswith(URL_PREFIXES):
        return f"a stream URL starts with one of {', '.join(URL_PREFIXES)}"
    return ""


@dataclass(frozen=True)
class SourceOptions(Options):
    """What the source reads and how fast it publishes."""

    video: str | None = option(None, "video file", metavar="FILE")
    camera: int | None = option(None, "camera index (OpenCV)", metavar="INDEX",
                                check=in_range(0, 63))
    url: str | None = option(None, "stream URL (rtsp://, http://, ...)", check=_url_problem)
    pace: str = option("realtime", "realtime: the file's frame rate; fast: as fast as fits "
                       "come back", choices=PACES)
    loop: int = option(1, "play a file N times (0: until stopped)", metavar="N",
                       check=in_range(0))
    jpeg: int = option(0, "publish JPEG frames of this quality (1-100) instead of raw (0)",
                       metavar="QUALITY", check=in_range(0, 100))
    window: int = option(2, "fast pacing: frames published ahead of the last fit",
                         check=in_range(1, 64))
    answer_timeout: float = option(1.0, "fast pacing: seconds to wait for a fit before going on",
                                   check=in_range(0.01, 60))
    shm_frames: int = option(POOL_IMAGES, "frames the shared-memory pool holds, each written "
                             "into it once (0: none, every one over the network)", metavar="N",
                             check=in_range(0, 256))
    max_frames: int = option(0, "stop after N frames (0: no limit)", metavar="N",
                             check=in_range(0))
    wait_for: tuple[str, ...] = option((), "a service to wait for before the first frame, "
                                       "repeatable", metavar="SERVICE")
    wait_timeout: float = option(60.0, "seconds to wait for --wait-for services (then go on)",
                                 check=in_range(0))

    def __post_init__(self) -> None:
        super().__post_init__()
        given = [x is not None for x in (self.video, self.camera, self.url)]
        if sum(given) > 1:
            raise OptionError("give one of --video, --camera and --url, not several")

    @property
    def has_input(self) -> bool:
        return any(x is not None for x in (self.video, self.camera, self.url))
