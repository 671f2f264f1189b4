"""The face detector: Haar cascade on request, and at a low rate while no face is tracked.

``aamtrack service detector [--rate HZ]``

- **On request**: a queryable on ``aamtrack/<stream>/detect``. The query
  payload is an encoded ``Frame``; the reply is the ``FaceBoxes`` found in it
  (an error reply names a frame that does not decode). The fitter asks when it
  has no face or a fit fails.
- **Searching**: while no good fit has been published for ``--idle`` seconds,
  the latest frame is searched ``--rate`` times a second.

Every result is also published on ``aamtrack/<stream>/boxes``. Haar cascades
give no confidence, so each box scores 1.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from proto import FaceBoxes, Frame, ProtoError, encode
from proto.keys import detect_key
from services.bus.args import parse_service_args
from services.bus.images import image_of
from services.bus.inbox import Latest
from services.bus.process import init_process
from services.bus.session import Service
from services.detector.options import DetectorOptions

NAME = "detector"


class Detection:
    """One detector shared by the query thread and the search loop (calls are serialised)."""

    def __init__(self, svc: Service, detector: HaarFaceDetector) -> None:
        self.svc = svc
        self.detector = detector
        self.lock = threading.Lock()

    def boxes(self, frame: Frame) -> FaceBoxes:
        """Detect in ``frame`` and return the boxes message for it."""
        image = image_of(frame)
        started = time.perf_counter()
        with self.lock:
            found = self.detector.detect(image)
        self.svc.stats.latency.add(1000 * (time.perf_counter() - started))
        return FaceBoxes(self.svc.header_for(frame), frame.width, frame.height,
                         found.astype(np.float32), np.ones(len(found), np.float32))

    def answer(self, query: Any) -> None:
        """Queryable callback: reply with the boxes of the frame in the query."""
        payload = query.payload.to_bytes() if query.payload is not None else b""
        frame = self.svc.screen.check(payload, str(query.key_expr), "frame")
        if frame is None:
            query.reply_err(b"the query payload is not a valid frame message of this run")
            return
        self.svc.stats.count_in(frame.header)
        try:
            boxes = self.boxes(frame)
        except (ProtoError, ValueError) as exc:
            self.svc.reject("detect query", str(exc))
            query.reply_err(str(exc).encode()[:1000])
            return
        data = encode(boxes)
        query.reply(query.key_expr, data)
        self.svc.publish(boxes)


class Tracking:
    """Whether the fitter holds a face: the time of its last good fit."""

    def __init__(self, svc: Service) -> None:
        self.svc = svc
        self.last_good = 0.0

    def on_fit(self, sample: Any) -> None:
        fit = self.svc.screen.check(sample.payload.to_bytes(), str(sample.key_expr), "fit")
        if fit is not None and not fit.failed:
            self.last_good = time.monotonic()

    def lost_for(self) -> float:
        return time.monotonic() - self.last_good


def search(svc: Service, detection: Detection, frames: Latest) -> None:
    """Detect in the latest frame, if any, and publish its boxes."""
    got = frames.take()
    if got is None:
        return
    svc.stats.count_in(got.message.header)
    try:
        svc.publish(detection.boxes(got.message))
    except (ProtoError, ValueError) as exc:
        svc.reject("frame", str(exc))


def serve(svc: Service, detector: HaarFaceDetector, opts: DetectorOptions) -> None:
    """Answer queries and search while no face is tracked, until stopped."""
    detection = Detection(svc, detector)
    tracking = Tracking(svc)
    svc.queryable(detect_key(svc.stream), detection.answer)
    svc.subscribe(svc.key("fit"), tracking.on_fit)
    frames = svc.latest("frame") if opts.rate > 0 else None
    svc.ready(f"{detector!r}")
    period = 1.0 / opts.rate if opts.rate > 0 else 1.0
    while not svc.wait(period):
        if frames is not None and tracking.lost_for() >= opts.idle:
            search(svc, detection, frames)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.detector.service``."""
    args = parse_service_args(NAME, "Haar face detection on request and while no face is "
                              "tracked.", DetectorOptions, argv)
    log = init_process(NAME, args.verbose)
    opts: DetectorOptions = args.options
    try:
        detector = HaarFaceDetector(scale_factor=opts.scale_factor,
                                    min_neighbors=opts.min_neighbors,
                                    min_size=(opts.min_size, opts.min_size),
                                    max_side=opts.max_side or None)
    except (FileNotFoundError, RuntimeError, ValueError) as exc:
        log.error("cannot make the Haar detector: %s", exc)
        return 1
    with Service(NAME, args.bus) as svc:
        serve(svc, detector, opts)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
