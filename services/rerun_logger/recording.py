"""Open a Rerun recording headless: to an ``.rrd`` file and/or a gRPC server on loopback.

``rr.init(spawn=True)`` needs a display (without one it blocks and drops
data), and Rerun's gRPC server binds every interface unless told otherwise, so
this module builds the sinks itself and binds the server to 127.0.0.1.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

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
    """

    stream: rr.RecordingStream
    rrd_path: Path | None
    serve_uri: str | None

    def close(self) -> None:
        """Flush everything and close the file and the server.

        The file gets its footer only here: a recording that is never closed
        leaves a file without one (still readable as a stream, but cut short).
        """
        try:
            self.stream.flush(timeout_sec=FLUSH_TIMEOUT_S)
        finally:
            self.stream.disconnect()


def open_recording(
    rrd_path: str | Path | None = None,
    serve_port: int | None = None,
    blueprint: rrb.Blueprint | None = None,
    application_id: str = APPLICATION_ID,
    recording_id: str | None = None,
) -> Recording:
    """Create a recording stream logging to a file and/or a loopback gRPC server.

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

    Raises
    ------
    ValueError
        When neither a file nor a port is given, the file's folder does not
        exist, or the port is outside 1 to 65535.
    """
    if rrd_path is None and serve_port is None:
        raise ValueError("give an .rrd path, a port to serve on, or both")
    sinks: list[rr.FileSink | rr.GrpcServerSink] = []
    path = None
    if rrd_path is not None:
        path = Path(rrd_path)
        if not path.parent.is_dir():
            raise ValueError(f"folder of the .rrd file does not exist: {path.parent}")
        sinks.append(rr.FileSink(path))
    server = None
    if serve_port is not None:
        if not 1 <= serve_port <= 65535:
            raise ValueError(f"port {serve_port} is outside 1 to 65535")
        server = rr.GrpcServerSink(bind_ip=LOOPBACK, port=serve_port)
        sinks.append(server)
    stream = rr.RecordingStream(application_id, recording_id=recording_id)
    stream.set_sinks(*sinks, default_blueprint=blueprint)
    uri = server.uri if server is not None else None
    if uri is not None:
        logger.info("rerun viewer: rerun %s", uri)
    return Recording(stream, path, uri)
