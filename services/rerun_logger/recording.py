"""Open a Rerun recording headless: to an ``.rrd`` file, a gRPC server on loopback, a viewer.

``rr.init(spawn=True)`` needs a display (without one it blocks and drops
data), and Rerun's gRPC server binds every interface unless told otherwise, so
this module builds the sinks itself and binds the server to 127.0.0.1. A
viewer that is already running (``rerun``, or ``rerun --serve-grpc``) is
tried before its sink is made: Rerun's own client would buffer and then drop
everything without a word (see :mod:`services.rerun_logger.viewer`).

A file ends with Rerun's footer, the index of its chunks, written when the recording is
closed: ``rerun rrd verify`` and Rerun's lazy loading need it. Rerun keeps that index in
memory until then, about 3.5 kB a chunk (measured on the stack's own messages), and makes a
chunk per entity each time it flushes its batches. At its default 0.2 s, the stack's
messages replayed at 16 frames/s made 25,611 chunks in 210 s and the process grew 18 % in
its last 150 s; at 5 s, 399 chunks and no growth. A recording that goes to a file only is
therefore batched into chunks of up to :data:`FILE_FLUSH_S` seconds per entity; one that a
viewer watches live keeps Rerun's default, so that each frame shows at once (its file's
index then grows with the run).
"""

from __future__ import annotations

import logging
import shutil
from dataclasses import dataclass
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

from services.rerun_logger.viewer import check_viewer

logger = logging.getLogger(__name__)

APPLICATION_ID = "aamtrack"
LOOPBACK = "127.0.0.1"
FLUSH_TIMEOUT_S = 30.0
FULL_BYTES = 1 << 20
"""Free bytes under which a folder's device is called full."""
FILE_FLUSH_S = 5.0
"""Seconds of data per entity in a chunk of a recording that goes to a file only."""
FILE_FLUSH_BYTES = 2 * 2**20
"""Bytes per entity that flush its chunk sooner (Rerun's default: the video's frames about
every second), so that little of the images waits in memory."""


def file_batching() -> rr.ChunkBatcherConfig:
    """Rerun's batching for a recording that goes to a file only (see the module notes)."""
    return rr.ChunkBatcherConfig(flush_tick=FILE_FLUSH_S, flush_num_bytes=FILE_FLUSH_BYTES)


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

    def flush(self, timeout: float = FLUSH_TIMEOUT_S) -> str:
        """Send everything logged so far; ``""``, or Rerun's error: the file could not be
        written (a full disk: :meth:`file_problem` says so) or a viewer is gone (a warning)."""
        try:
            self.stream.flush(timeout_sec=timeout)
        except RuntimeError as exc:
            if not self.file_problem(str(exc)):
                logger.warning("not everything reached the viewer: %s", exc)  # it went away
            return str(exc)
        return ""

    def file_problem(self, error: str = "") -> str:
        """Why the file is no longer written, from the error of a flush (Rerun's file writer
        stops at the first write that fails), or ``""``."""
        if self.rrd_path is None or "file" not in error.lower():
            return ""
        folder = self.rrd_path.parent
        try:
            full = shutil.disk_usage(folder).free < FULL_BYTES
        except OSError:
            full = False
        why = "no space left on the device" if full else error
        return f"{self.rrd_path}: cannot be written ({why})"

    def close(self) -> str:
        """Flush everything and close the file and the server; ``""``, or what went wrong
        (:meth:`flush`).

        A file written with its footer gets it only here (a recording that is never closed
        leaves a file without one, still readable as a stream). A viewer that went away
        loses what it did not get; the file does not.
        """
        try:
            return self.flush()
        finally:
            self.stream.disconnect()


def open_recording(
    rrd_path: str | Path | None = None, serve_port: int | None = None,
    blueprint: rrb.Blueprint | None = None, application_id: str = APPLICATION_ID,
    recording_id: str | None = None, viewer_url: str | None = None,
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
        sinks.append(rr.FileSink(path))
    server = None
    if serve_port is not None:
        if not 1 <= serve_port <= 65535:
            raise ValueError(f"port {serve_port} is outside 1 to 65535")
        server = rr.GrpcServerSink(bind_ip=LOOPBACK, port=serve_port)
        sinks.append(server)
    if viewer is not None:
        sinks.append(rr.GrpcSink(viewer.url))
    live = server is not None or viewer is not None
    stream = rr.RecordingStream(application_id, recording_id=recording_id,
                                batcher_config=None if live else file_batching())
    stream.set_sinks(*sinks, default_blueprint=blueprint)
    uri = server.uri if server is not None else None
    if uri is not None:
        logger.info("rerun viewer: rerun %s", uri)
    if viewer is not None:
        logger.info("streaming to the Rerun viewer at %s", viewer.url)
    return Recording(stream, path, uri, viewer.url if viewer is not None else None)
