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

import argparse
import threading
import time
from typing import Any

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from proto import FaceBoxes, Frame, ProtoError, encode
from proto.keys import detect_key
from services.bus.runtime import BusOptions, Service, image_of, init_process, service_parser

NAME = "detector"


def build_parser() -> argparse.ArgumentParser:
    parser = service_parser(NAME, "Haar face detection on request and while no face is tracked.")
    parser.add_argument("--rate", type=float, default=2.0,
                        help="searches a second while no face is tracked (0: only on request)")
    parser.add_argument("--idle", type=float, default=1.0,
                        help="seconds without a good fit after which to search")
    parser.add_argument("--scale-factor", type=float, default=1.2, help="Haar scale step")
    parser.add_argument("--min-size", type=int, default=60, help="smallest face side, pixels")
    parser.add_argument("--max-side", type=int, default=320,
                        help="downscale frames to this longer side before detecting (0: never)")
    return parser


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
        header = self.svc.header(frame.header.frame_index, frame.header.capture_time_ns)
        return FaceBoxes(header, frame.width, frame.height, found.astype(np.float32),
                         np.ones(len(found), np.float32))

    def answer(self, query: Any) -> None:
        """Queryable callback: reply with the boxes of the frame in the query."""
        payload = query.payload.to_bytes() if query.payload is not None else b""
        frame = self.svc.decode(payload, "frame", source="detect query")
        if frame is None:
            query.reply_err(b"the query payload is not a valid frame message")
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
        self.svc.put(boxes.key(), data)
        self.svc.stats.frames_out += 1


class Tracking:
    """Whether the fitter holds a face: the time of its last good fit."""

    def __init__(self, svc: Service) -> None:
        self.svc = svc
        self.last_good = 0.0

    def on_fit(self, sample: Any) -> None:
        fit = self.svc.decode(sample.payload.to_bytes(), "fit", source="fit")
        if fit is not None and not fit.failed:
            self.last_good = time.monotonic()

    def lost_for(self) -> float:
        return time.monotonic() - self.last_good


class LatestSample:
    """The last sample of a key, not decoded until asked for."""

    def __init__(self) -> None:
        self.sample: Any = None
        self.seen = 0

    def on_sample(self, sample: Any) -> None:
        self.sample = sample
        self.seen += 1

    def take(self) -> Any:
        sample, self.sample = self.sample, None
        return sample


def search(svc: Service, detection: Detection, latest: LatestSample) -> None:
    """Detect in the latest frame, if any, and publish its boxes."""
    sample = latest.take()
    if sample is None:
        return
    frame = svc.decode(sample.payload.to_bytes(), "frame", source="frame")
    if frame is None:
        return
    svc.stats.count_in(frame.header)
    try:
        svc.publish(detection.boxes(frame))
    except (ProtoError, ValueError) as exc:
        svc.reject("frame", str(exc))


def run(args: argparse.Namespace) -> int:
    """Run the detector with parsed arguments; the exit code."""
    log = init_process(NAME, args.verbose)
    try:
        detector = HaarFaceDetector(scale_factor=args.scale_factor,
                                    min_size=(args.min_size, args.min_size),
                                    max_side=args.max_side or None)
    except (FileNotFoundError, RuntimeError, ValueError) as exc:
        log.error("cannot make the Haar detector: %s", exc)
        return 1
    with Service(NAME, BusOptions.from_args(args)) as svc:
        detection = Detection(svc, detector)
        tracking = Tracking(svc)
        latest = LatestSample()
        svc.queryable(detect_key(svc.stream), detection.answer)
        svc.subscribe(svc.key("fit"), tracking.on_fit)
        if args.rate > 0:
            svc.subscribe(svc.key("frame"), latest.on_sample)
        svc.ready(f"{detector!r}")
        period = 1.0 / args.rate if args.rate > 0 else 1.0
        while not svc.wait(period):
            if args.rate > 0 and tracking.lost_for() >= args.idle:
                search(svc, detection, latest)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point: ``python -m services.detector.service``."""
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
