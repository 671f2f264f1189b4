"""The face detector: Haar cascade on request.

``aamtrack service detector [--scale-factor F] [--min-neighbors N] [--max-side PX]``

A queryable on ``aamtrack/<stream>/detect``: the query payload is an encoded
``Frame``, the reply the ``FaceBoxes`` found in it (an error reply names a frame
that does not decode). The fitter asks when it has no face or a fit fails, on the
frames its search schedule picks (:class:`aamcore.fitting.search.SearchSchedule`):
that is the only search, so no frame is searched twice. Every answer is also
published on ``aamtrack/<stream>/boxes`` (the Rerun logger draws them). Haar
cascades give no confidence, so each box scores 1. Every reply's attachment is
the detector's search settings (JSON of ``HaarFaceDetector.settings()``): the
fitter's local fall-back searches with them while this service is gone.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from aamcore.operators.detect import DetectOperator
from proto import FaceBoxes, Frame, ProtoError
from proto.keys import detect_key
from services.bus.args import parse_service_args
from services.bus.images import image_of
from services.bus.process import init_process
from services.bus.session import Service
from services.detector.options import DetectorOptions

NAME = "detector"


class Detection:
    """One detector shared by the query threads (calls are serialised)."""

    def __init__(self, svc: Service, detector: DetectOperator) -> None:
        self.svc = svc
        self.detector = detector
        self.lock = threading.Lock()
        self.settings = json.dumps(detector.settings()).encode()
        """Sent with every reply, so that a fitter that detects locally while this service
        is gone searches as it does."""

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
        data = self.svc.encode(boxes)
        query.reply(query.key_expr, data, attachment=self.settings)
        self.svc.publish(boxes)


def serve(svc: Service, detector: DetectOperator) -> None:
    """Answer queries until stopped."""
    detection = Detection(svc, detector)
    svc.queryable(detect_key(svc.stream), detection.answer)
    svc.ready(f"{detector!r}")
    while not svc.wait(1.0):
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.detector.service``."""
    args = parse_service_args(NAME, "Haar face detection on request.", DetectorOptions, argv)
    log = init_process(NAME, args.verbose)
    opts: DetectorOptions = args.options
    try:
        detector = DetectOperator(opts.detect)
    except (FileNotFoundError, RuntimeError, ValueError) as exc:
        log.error("cannot make the Haar detector: %s", exc)
        return 1
    with Service(NAME, args.bus) as svc:
        serve(svc, detector)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
