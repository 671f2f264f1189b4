"""Open a Rerun recording headless: to an ``.rrd`` file, a gRPC server on loopback, a viewer.

``rr.init(spawn=True)`` needs a display (without one it blocks and drops
data), and Rerun's gRPC server binds every interface unless told otherwise, so
this module builds the sinks itself and binds the server to 127.0.0.1. A
viewer that is already running (``rerun``, or ``rerun --serve-grpc``) is
tried before its sink is made: Rerun's own client would buffer and then drop
everything without a word (see :mod:`services.rerun_logger.viewer`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

from services.rerun_logger.viewer import check_viewer

logger = logging.getLogger(__name__)

APPLICATION_ID = "aamtrack"
LOOPBACK = "127.0.0.1"
FLUSH_TIMEOUT_S = 30.0


@dataclass
class Recording:
    """A recording stream and where it goes.

    Attributes
    ----------
    stream : rerun.RecordingStream
    rrd_path : Path or None
        The ``.rrd`` file written, if any.
    serve_uri : str or None
        URI a viewer connects to (``rerun <uri>``), if a server was started.
    viewer_url : str or None
        URL of the running viewer the recording streams to, if any.
    """

    stream: rr.RecordingStream
    rrd_path: Path | None
    serve_uri: str | None
    viewer_url: str | None = None

    def flush(self, timeout: float = FLUSH_TIMEOUT_S) -> bool:
        """Send everything logged so far; False (with a warning) when a viewer is gone."""
        try:
            self.stream.flush(timeout_sec=timeout)
        except RuntimeError as exc:  # a gRPC sink whose viewer went away
            logger.warning("not everything reached the viewer: %s", exc)
            return False
        return True

    def close(self) -> None:
        """Flush everything and close the file and the server.

        A file written with its footer gets it only here (a recording that is never closed
        leaves a file without one, still readable as a stream). A viewer that went away
        loses what it did not get; the file does not.
        """
        try:
            self.flush()
        finally:
            self.stream.disconnect()


def open_recording(
    rrd_path: str | Path | None = None, serve_port: int | None = None,
    blueprint: rrb.Blueprint | None = None, application_id: str = APPLICATION_ID,
    recording_id: str | None = None, viewer_url: str | None = None, footer: bool = True,
) -> Recording:
    """Create a recording stream logging to a file, a loopback gRPC server and/or a viewer.

    Parameters
    ----------
    rrd_path : path, optional
        ``.rrd`` file to write (its folder must exist); an existing file is replaced.
    serve_port : int, optional
        Port of a gRPC server on 127.0.0.1 that viewers connect to
        (``rerun rerun+http://127.0.0.1:<port>/proxy``); 0 is not allowed.
    blueprint : rerun.blueprint.Blueprint, optional
        Default layout sent with the recording.
    application_id, recording_id : str
        Rerun's identifiers; the recording id defaults to a random one.
    viewer_url : str, optional
        A running viewer to stream to: ``rerun+http://HOST:PORT/proxy`` or a
        port (see :func:`services.rerun_logger.viewer.viewer_address`).
    footer : bool
        End the file with Rerun's index of its chunks, which Rerun keeps in memory until
        then (1 MB/s at the fastest pacing): the long-running logger writes none.

    Raises
    ------
    ValueError
        When no output is given, the file's folder does not exist, the port
        is outside 1 to 65535, or the viewer URL is malformed or nothing
        listens there (:class:`~services.rerun_logger.viewer.ViewerError`).
    """
    if rrd_path is None and serve_port is None and viewer_url is None:
        raise ValueError("give an .rrd path, a port to serve on, or a viewer URL")
    viewer = check_viewer(viewer_url) if viewer_url is not None else None
    sinks: list[rr.FileSink | rr.GrpcServerSink | rr.GrpcSink] = []
    path = None
    if rrd_path is not None:
        path = Path(rrd_path)
        if not path.parent.is_dir():
            raise ValueError(f"folder of the .rrd file does not exist: {path.parent}")
        sinks.append(rr.FileSink(path, write_footer=footer))
    server = None
    if serve_port is not None:
        if not 1 <= serve_port <= 65535:
            raise ValueError(f"port {serve_port} is outside 1 to 65535")
        server = rr.GrpcServerSink(bind_ip=LOOPBACK, port=serve_port)
        sinks.append(server)
    if viewer is not None:
        sinks.append(rr.GrpcSink(viewer.url))
    stream = rr.RecordingStream(application_id, recording_id=recording_id)
    stream.set_sinks(*sinks, default_blueprint=blueprint)
    uri = server.uri if server is not None else None
    if uri is not None:
        logger.info("rerun viewer: rerun %s", uri)
    if viewer is not None:
        logger.info("streaming to the Rerun viewer at %s", viewer.url)
    return Recording(stream, path, uri, viewer.url if viewer is not None else None)
