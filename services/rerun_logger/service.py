"""The Rerun logging service: every message of a stream into an ``.rrd`` file and/or a viewer.

``aamtrack service rerun --rrd out.rrd`` (or ``python -m
services.rerun_logger.service``) subscribes to the stream's frames, boxes,
fits, poses, expressions, overlays, end of stream and the status of every
service, and logs them with :class:`~services.rerun_logger.dispatch.StreamLogger`.

- Frames and overlays go through inboxes that keep only the latest few, so a
  logger that cannot keep up skips video rather than falling behind; results
  are kept in deeper inboxes.
- A message that does not decode is counted as rejected and its reason logged
  once (:meth:`services.bus.runtime.Service.reject`).
- On end of stream the service goes on until nothing has arrived for
  ``--idle`` seconds (the results of the last frames come after the end of
  stream message), at most ``--grace`` seconds; on SIGTERM or SIGINT it stops
  at once. Either way the recording is flushed and its file closed.
"""

from __future__ import annotations

import argparse
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from aamcore.pose.errors import PoseError
from aamcore.pose.head_model import HeadModel, openface68
from proto.keys import status_wildcard
from proto.messages import EndOfStream
from services.bus.runtime import BusOptions, Inbox, Service, init_process, service_parser
from services.rerun_logger.blueprint import build_blueprint
from services.rerun_logger.dispatch import StreamLogger
from services.rerun_logger.images import DEFAULT_QUALITY
from services.rerun_logger.recording import open_recording

NAME = "rerun"
"""Service name: status on ``aamtrack/<stream>/status/rerun``."""
IMAGE_BACKLOG = 2
"""Frames (and overlays) kept waiting; older ones are dropped."""
RESULT_BACKLOG = 256
"""Boxes, fits, poses, expressions and statuses kept waiting."""
POLL_S = 0.005
"""Sleep between polls of the inboxes when all are empty."""
MAX_PER_ROUND = 64
"""Messages taken from one inbox before the next inbox gets its turn."""

_log = logging.getLogger(f"aamtrack.{NAME}")


def build_parser() -> argparse.ArgumentParser:
    """The service's argument parser (bus options plus the Rerun outputs)."""
    parser = service_parser(NAME, "Log a stream's messages to Rerun (.rrd file and/or viewer).")
    out = parser.add_argument_group("rerun")
    out.add_argument("--rrd", type=Path, metavar="PATH", help="write the recording to this file")
    out.add_argument(
        "--serve", type=int, metavar="PORT",
        help="serve the recording over gRPC on 127.0.0.1:PORT for a viewer",
    )
    out.add_argument(
        "--linger", type=float, default=0.0, metavar="S",
        help="with --serve: keep serving S seconds after the stream ends (default 0)",
    )
    out.add_argument(
        "--jpeg-quality", type=int, default=DEFAULT_QUALITY, metavar="Q",
        help=f"JPEG quality for raw frames and overlays (default {DEFAULT_QUALITY})",
    )
    out.add_argument(
        "--no-head-model", action="store_true", help="do not draw the 3D head model with the pose"
    )
    out.add_argument(
        "--idle", type=float, default=1.0, metavar="S",
        help="after end of stream, stop once nothing arrived for S seconds (default 1)",
    )
    out.add_argument(
        "--grace", type=float, default=10.0, metavar="S",
        help="after end of stream, stop after S seconds at most (default 10)",
    )
    return parser


def load_head_model(enabled: bool = True) -> HeadModel | None:
    """The OpenFace mean 68-point head model, or ``None`` if disabled or unreadable."""
    if not enabled:
        return None
    try:
        return openface68()
    except PoseError as exc:
        _log.warning("no head model drawn: %s", exc)
        return None


@dataclass
class Inputs:
    """The inboxes of one stream, in the order they are polled."""

    inboxes: list[Inbox] = field(default_factory=list)

    @classmethod
    def subscribe(cls, svc: Service) -> Inputs:
        """Subscribe ``svc`` to everything the logger shows."""
        inputs = cls()
        for kind in ("eos", "boxes", "fit", "pose", "expression"):
            inputs.inboxes.append(svc.inbox(kind, capacity=RESULT_BACKLOG))
        inputs.inboxes.append(
            svc.inbox(status_wildcard(svc.stream), capacity=RESULT_BACKLOG, kind="status")
        )
        for kind in ("frame", "overlay"):
            inputs.inboxes.append(svc.inbox(kind, capacity=IMAGE_BACKLOG))
        return inputs


def log_pending(inputs: Inputs, logger: StreamLogger, svc: Service) -> tuple[int, bool]:
    """Log the messages waiting in the inboxes (at most :data:`MAX_PER_ROUND` from each).

    A message the logger cannot log (an error of Rerun or of an image codec)
    is counted as rejected, like one that does not decode, and the service
    goes on.

    Returns
    -------
    logged : int
        Messages logged.
    ended : bool
        Whether one of them was an end of stream.
    """
    logged, ended = 0, False
    for inbox in inputs.inboxes:
        for _ in range(MAX_PER_ROUND):
            got = inbox.get(timeout=0)
            if got is None:
                break
            try:
                logger.log(got.message)
            except (ValueError, TypeError, RuntimeError) as exc:
                svc.reject(got.key, f"{got.message.KIND} not logged: {exc}")
                continue
            svc.stats.latency.add((time.time_ns() - got.received_ns) / 1e6)
            logged += 1
            ended |= isinstance(got.message, EndOfStream)
    return logged, ended


def run(
    svc: Service, inputs: Inputs, logger: StreamLogger, idle_s: float, grace_s: float
) -> None:
    """Log until stopped, or until the stream ended and went quiet (see the module notes)."""
    ended_at: float | None = None
    last_at = time.monotonic()
    while not svc.stopping:
        logged, ended = log_pending(inputs, logger, svc)
        now = time.monotonic()
        if logged:
            last_at = now
        if ended and ended_at is None:
            ended_at = now
            svc.set_state("stopping", "end of stream")
            _log.info("end of stream; logging the last results")
        if ended_at is not None and (now - last_at >= idle_s or now - ended_at >= grace_s):
            return
        if not logged:
            svc.wait(POLL_S)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the service; return the exit code (0 after end of stream or a stop signal)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.rrd is None and args.serve is None:
        parser.error("give --rrd PATH, --serve PORT, or both")
    if not 1 <= args.jpeg_quality <= 100:
        parser.error(f"--jpeg-quality {args.jpeg_quality} is outside 1 to 100")
    try:
        bus = BusOptions.from_args(args)
    except ValueError as exc:
        parser.error(str(exc))
    init_process(NAME, args.verbose)
    with Service(NAME, bus) as svc:
        try:
            recording = open_recording(args.rrd, args.serve, build_blueprint())
        except (ValueError, OSError, RuntimeError) as exc:
            _log.error("cannot open the recording: %s", exc)
            svc.set_state("failed", f"cannot open the recording: {exc}")
            return 2
        try:
            logger = StreamLogger(
                recording.stream, load_head_model(not args.no_head_model), args.jpeg_quality
            )
            inputs = Inputs.subscribe(svc)
            svc.set_state("running")
            run(svc, inputs, logger, args.idle, args.grace)
            if args.serve is not None and args.linger > 0 and not svc.stopping:
                _log.info("serving for %.1f s more", args.linger)
                svc.wait(args.linger)
            _log.info("logged %s", logger.counts)
        finally:
            recording.close()
    if recording.rrd_path is not None:
        _log.info("recording written to %s", recording.rrd_path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
