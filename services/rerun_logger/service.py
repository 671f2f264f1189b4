"""The Rerun logging service: every message of a stream into an ``.rrd`` file and/or a viewer.

``aamtrack service rerun --rrd out.rrd`` subscribes to the stream's frames,
boxes, fits, poses, expressions, overlays, end of stream and the status of
every service, and logs them with
:class:`~services.rerun_logger.dispatch.StreamLogger`. The recording goes to
a file (``--rrd``/``--save``), to a gRPC server of the service's own on
loopback (``--serve PORT``), to a viewer that runs already (``--viewer
[URL]``), or to several of them.

- Frames and overlays go through inboxes that keep only the latest few, so a
  logger that cannot keep up skips video rather than falling behind; results
  are kept in deeper inboxes.
- On end of stream the service goes on until nothing has arrived for
  ``--idle`` seconds (the results of the last frames come after the end of
  stream message), at most ``--grace`` seconds; on a stop signal it stops at
  once. Either way the recording is flushed and its file closed.
- With ``--serve``, the service goes on serving after the end of stream, so
  that viewers can still connect, until a stop signal (SIGINT, SIGTERM) or,
  with ``--linger S``, for S seconds more; the file is complete once it stops.
- A viewer given with ``--viewer`` that does not answer stops the service at
  start, with one line saying so and exit code 2: nothing is streamed into
  the void. A viewer that goes away later loses the rest; the file does not.
- A restarted service never overwrites what its first run wrote: it writes a
  new part beside it (``run.part1.rrd``, ...), of the same recording id.
- Only the run's messages are logged: inside a run the launcher hands the logger the run's
  public keys; started on its own it fetches them from the run's launcher (``--trust FP``
  names its key; without it, the only launcher that answers) and checks every message, or
  logs everything with ``--unverified``. The recording says which, in its events.
- The file ends with Rerun's footer, written when the service stops (at the end of
  stream or on a stop signal), and its memory stays flat over a long run (see
  :mod:`services.rerun_logger.recording`); the part of a process that was killed is
  finished by the launcher (:mod:`services.rerun_logger.files`).
- A file that can no longer be written (a full disk) stops the service: it exits 0 (a
  restart would not help) with its last status "failed" naming the file, which ends the
  run with that line (:mod:`services.stack.outcome`); what was written before is kept.
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Sequence

from aamcore.ar.glasses_mesh import GlassesMesh, mean_head_glasses
from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel, openface68
from proto.keys import IMAGES, RESULTS, status_wildcard
from proto.messages import EndOfStream
from services.bus.args import parse_service_args
from services.bus.options import OptionError
from services.bus.process import init_process
from services.bus.session import Service
from services.rerun_logger.blueprint import build_blueprint
from services.rerun_logger.dispatch import StreamLogger
from services.rerun_logger.files import part_path
from services.rerun_logger.options import RerunOptions
from services.rerun_logger.recording import Recording, open_recording

NAME = "rerun"
"""Service name: status on ``aamtrack/<stream>/status/rerun``."""
IMAGE_BACKLOG = 2
"""Frames (and overlays) kept waiting; older ones are dropped."""
RESULT_BACKLOG = 256
"""Boxes, fits, poses, expressions and statuses kept waiting."""
CHECK_S = 30.0
"""Seconds between two looks at whether the file is still written (a full disk): each
flushes Rerun's batches once (:mod:`services.rerun_logger.recording`)."""

_log = logging.getLogger(f"aamtrack.{NAME}")


def load_head_model(enabled: bool = True) -> HeadModel | None:
    """The OpenFace mean 68-point head model, or ``None`` if disabled or unreadable."""
    if not enabled:
        return None
    try:
        return openface68()
    except PoseError as exc:
        _log.warning("no head model drawn: %s", exc)
        return None


def load_glasses(enabled: bool = True) -> GlassesMesh | None:
    """The AR glasses on the mean head, or ``None`` if disabled or not buildable."""
    if not enabled:
        return None
    try:
        return mean_head_glasses()
    except (PoseError, ValueError, OSError) as exc:
        _log.warning("no glasses drawn: %s", exc)
        return None


def inputs(svc: Service) -> dict[str, tuple[str, int]]:
    """What the logger shows, results before images: ``{kind or key: (kind, capacity)}``."""
    wanted = {kind: (kind, RESULT_BACKLOG) for kind in ("eos", *RESULTS)}
    wanted[status_wildcard(svc.stream)] = ("status", RESULT_BACKLOG)
    wanted |= {kind: (kind, IMAGE_BACKLOG) for kind in IMAGES}
    return wanted


def log_stream(svc: Service, logger: StreamLogger, opts: RerunOptions,
               recording: Recording | None = None) -> str:
    """Log until stopped, or until the stream ended and went quiet (see the module notes);
    ``""``, or why the file could not be written (looked at every :data:`CHECK_S`)."""
    ended_at: float | None = None
    last_at = checked_at = time.monotonic()
    for got in svc.messages_of(inputs(svc), tick=0.05):
        now = time.monotonic()
        if recording is not None and recording.rrd_path is not None and (
                now - checked_at >= CHECK_S):
            checked_at = now
            if problem := recording.file_problem(recording.flush()):
                return problem
        if got is not None:
            logged = False
            with svc.answering(f"{got.message.KIND} {got.message.header.frame_index}"):
                try:
                    logger.log(got.message)
                    logged = True
                except (ValueError, TypeError, RuntimeError) as exc:
                    svc.reject(got.key, f"{got.message.KIND} not logged: {exc}")
            if not logged:
                continue
            last_at = now
            if isinstance(got.message, EndOfStream) and ended_at is None:
                ended_at = now
                svc.set_state("stopping", "end of stream")
                _log.info("end of stream; logging the last results")
        if ended_at is not None and (now - last_at >= opts.idle or now - ended_at >= opts.grace):
            return ""
    return ""


def serve_after_end(svc: Service, recording: Recording, linger: float | None) -> None:
    """Go on serving the recording after the end of stream: until stopped, or ``linger`` s."""
    recording.flush()  # everything logged is in the file and the server's buffer
    how = "until stopped" if linger is None else f"for {linger:g} s more"
    svc.set_state("waiting", f"end of stream; serving {recording.serve_uri} {how}")
    _log.info("end of stream; serving the recording %s: rerun --connect %s (Ctrl-C to stop)",
              how, recording.serve_uri)
    if linger is None:
        while not svc.wait(3600.0):
            pass
    else:
        svc.wait(linger)


def verification(svc: Service, opts: RerunOptions) -> str:
    """What the logged messages are checked against, in words; a logger started on its own
    fetches the run's public keys first (:meth:`Service.trust_run`).

    Raises
    ------
    OptionError
        When no run's keys can be trusted.
    """
    if not svc.keyring and not opts.unverified:
        svc.trust_run(svc.bus.trust)
    if svc.run_keys is not None:
        return (f"every message verified against run {svc.run_keys.run_id or '?'}, launcher "
                f"key {svc.run_keys.fingerprint}")
    if svc.keyring:
        return f"every message verified against the run's keys ({svc.run_id or 'any run'})"
    return "UNVERIFIED: no signature checked (--unverified)"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the service; return the exit code (0 after end of stream or a stop signal)."""
    args = parse_service_args(NAME, "Log a stream's messages to Rerun (.rrd file, gRPC "
                              "server and/or running viewer).", RerunOptions, argv)
    opts: RerunOptions = args.options
    if not opts.has_output:
        print("aamtrack service rerun: error: give --rrd PATH, --serve PORT and/or "
              "--viewer [URL]", file=sys.stderr)
        return 2
    init_process(NAME, args.verbose)
    with Service(NAME, args.bus) as svc:
        rrd = part_path(opts.rrd, svc.restarts) if opts.rrd else None
        try:
            recording = open_recording(rrd, opts.serve, build_blueprint(),
                                       recording_id=args.bus.run_id or None,
                                       viewer_url=opts.viewer)
        except (OSError, RuntimeError) as exc:  # the file's first bytes (a full disk)
            svc.set_state("failed", f"{rrd}: cannot be written ({exc})")
            return 0  # said by the launcher; a restart would not help
        except ValueError as exc:
            _log.error("cannot open the recording: %s", exc)
            svc.set_state("failed", f"cannot open the recording: {exc}")
            return 2
        problem = ""
        try:
            logger = StreamLogger(recording.stream, load_head_model(opts.head_model),
                                  opts.jpeg_quality, load_glasses(opts.glasses))
            try:
                logger.note(verification(svc, opts))
            except OptionError as exc:
                print(f"aamtrack service rerun: error: {exc}", file=sys.stderr)
                return 2
            problem = log_stream(svc, logger, opts, recording)
            _log.info("logged %s", logger.counts)
            if recording.serve_uri is not None and not svc.stopping and not problem:
                serve_after_end(svc, recording, opts.linger)
        finally:
            problem = problem or recording.file_problem(recording.close())
            if problem:  # a full disk: said once, by the launcher; no restart would help
                svc.set_state("failed", f"{problem}; what was written before is kept")
    if recording.rrd_path is not None and not problem:
        _log.info("recording written to %s", recording.rrd_path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
