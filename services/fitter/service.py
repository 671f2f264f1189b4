"""The fitter service: tracks the face from frame to frame and publishes one fit per frame.

``aamtrack service fitter [--model FILE] [--warp gpu|cpu]``

Each frame is fitted from the previous frame's parameters; when there is no
face yet or that fit fails, the fitter asks the detector service (a Zenoh
query on ``aamtrack/<stream>/detect`` carrying the frame) and fits from the
box it returns, as :class:`aamcore.fitting.fitter.Tracker` does with a local
detector. If the detector service does not answer within ``--detect-timeout``
seconds, the fitter detects locally for ``--local-for`` seconds (logged) and
then asks the service again.

Every frame taken gets a ``Fit``: a good one, a failed one (``failed`` with
the reason), or ``failed`` with reason ``no face`` and no landmarks. The warp
runs on the GPU worker thread (``aamcore.warp.worker``) or the CPU;
each fit names the path in ``warp_path``.
"""

from __future__ import annotations

import argparse
import logging
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.algorithm import ALGORITHMS
from aamcore.fitting.failure import FAILURE_TESTS
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.result import FitResult
from aamcore.fitting.tracker import Tracker
from aamcore.fitting.training.prepare import default_model_path
from aamcore.model.aam import AAM
from aamcore.warp.worker import make_warp
from proto import Fit, Frame, Header, ProtoError, decode, encode
from proto.keys import detect_key
from services.bus.runtime import (
    BusOptions,
    Received,
    Service,
    image_of,
    init_process,
    service_parser,
)

NAME = "fitter"
DEFAULT_ALGORITHM = "fixed-jacobian"
"""The tracker's algorithm: on ``single_face.mp4`` with the default LFPW model it fits in
about 3 ms a frame on one core and fails fewer frames than the supervised-descent
cascade (about 15 ms); see the report of ``bench/bench_stack.py``."""
NO_FACE = "no face"
EMPTY_POINTS = np.zeros((0, 2), np.float32)
EMPTY = np.zeros(0, np.float32)


def build_parser() -> argparse.ArgumentParser:
    parser = service_parser(NAME, "Fit the AAM to each frame and publish the fits.")
    parser.add_argument("--model", help="AAM model file (default: the cached LFPW model, "
                        "trained on first use)")
    parser.add_argument("--model-limit", type=int, default=0,
                        help="train the default model on the first N LFPW images only")
    parser.add_argument("--model-images", type=int, default=30,
                        help="images for the default model's update matrix")
    parser.add_argument("--algorithm", choices=ALGORITHMS, default=DEFAULT_ALGORITHM,
                        help=f"fitting algorithm (default {DEFAULT_ALGORITHM})")
    parser.add_argument("--failure-test", choices=FAILURE_TESTS, default="chi2",
                        help="how a failed fit is recognised: chi2 (Mahalanobis distance of "
                             "the appearance, default) or eq7.2 (any parameter beyond 3 sd, "
                             "the thesis's test, which flags many good fits of a large model)")
    parser.add_argument("--warp", choices=("auto", "gpu", "cpu"), default="auto",
                        help="where the image warp runs: auto (the GPU worker thread when "
                             "the GL renderer is a real GPU, else the CPU), gpu (falls back "
                             "to cpu without GL) or cpu")
    parser.add_argument("--detect-timeout", type=float, default=1.0,
                        help="seconds to wait for the detector service")
    parser.add_argument("--local-for", type=float, default=5.0,
                        help="seconds to detect locally after the service did not answer")
    parser.add_argument("--capacity", type=int, default=2,
                        help="latest frames kept while busy (older ones are dropped)")
    return parser


def model_path(args: argparse.Namespace) -> Path:
    """The model file to use: ``--model`` or the cached default (trained if needed)."""
    if args.model:
        return Path(args.model)
    return default_model_path(max_images=args.model_images, limit=args.model_limit or None)


class ServiceDetector:
    """Face detection through the detector service, with a local fallback.

    Has the ``detect(image) -> (K, 4)`` call that :class:`Tracker` expects.
    :meth:`set_frame` must name the frame (and its encoded payload) about to
    be tracked, so that the query carries the bytes received, not a re-encoding.

    Parameters
    ----------
    svc : Service
    timeout : float
        Seconds to wait for the service's reply.
    local_for : float
        Seconds to detect locally after the service failed to answer.
    """

    def __init__(self, svc: Service, timeout: float, local_for: float) -> None:
        self.svc = svc
        self.timeout = timeout
        self.local_for = local_for
        self.queries = 0
        self.local_detections = 0
        self._local: HaarFaceDetector | None = None
        self._local_until = 0.0
        self._image: np.ndarray | None = None
        self._payload = b""

    def set_frame(self, image: np.ndarray, payload: bytes) -> None:
        """The frame the next :meth:`detect` calls are about, and its encoded message."""
        self._image, self._payload = image, payload

    def detect(self, image: np.ndarray) -> np.ndarray:
        """Face boxes ``(K, 4)`` float64 ``x, y, w, h`` in ``image``, largest first."""
        if time.monotonic() >= self._local_until:
            boxes = self._ask(image)
            if boxes is not None:
                return boxes
            self._local_until = time.monotonic() + self.local_for
            self.svc.log.warning(
                "the detector service did not answer within %g s: detecting locally for %g s",
                self.timeout, self.local_for)
        return self._detect_locally(image)

    def _payload_for(self, image: np.ndarray) -> bytes:
        if image is self._image and self._payload:
            return self._payload
        height, width = image.shape[:2]
        return encode(Frame(self.svc.header(0), "raw", width, height, image))

    def _ask(self, image: np.ndarray) -> np.ndarray | None:
        self.queries += 1
        replies = self.svc.session.get(detect_key(self.svc.stream),
                                       payload=self._payload_for(image), timeout=self.timeout)
        for reply in replies:
            if reply.ok is None:
                self.svc.reject("detector reply", f"error reply: {_err_text(reply)}")
                continue
            try:
                boxes = decode(reply.ok.payload.to_bytes(), "boxes")
            except ProtoError as exc:
                self.svc.reject("detector reply", exc.reason)
                continue
            if (boxes.image_width, boxes.image_height) != (image.shape[1], image.shape[0]):
                self.svc.reject("detector reply", "boxes for a frame of another size")
                continue
            return boxes.boxes.astype(np.float64)
        return None

    def _detect_locally(self, image: np.ndarray) -> np.ndarray:
        if self._local is None:
            self._local = HaarFaceDetector()
        self.local_detections += 1
        return self._local.detect(image)


def _err_text(reply: Any) -> str:
    try:
        return reply.err.payload.to_bytes().decode(errors="replace")[:200]
    except Exception:  # an error reply without a readable payload
        return "no reason given"


def fit_message(header: Header, result: FitResult | None, scheme: str, warp_path: str) -> Fit:
    """The ``Fit`` message of a tracking result (``None``: no face found)."""
    if result is None:
        return Fit(header, scheme, EMPTY_POINTS, EMPTY, EMPTY, math.nan, 0, False, True,
                   NO_FACE, warp_path)
    finite = bool(np.all(np.isfinite(result.points)) and np.all(np.isfinite(result.c))
                  and np.all(np.isfinite(result.similarity.params)))
    error = float(result.error) if math.isfinite(result.error) else math.nan
    reason = result.reason or ("non-finite result" if not finite else "")
    failed = bool(result.failed or not finite)
    return Fit(
        header, scheme,
        result.points.astype(np.float32) if finite else EMPTY_POINTS,
        result.c.astype(np.float32) if finite else EMPTY,
        result.similarity.params.astype(np.float32) if finite else EMPTY,
        max(error, 0.0) if not math.isnan(error) else error,
        int(result.iterations),
        not failed and result.converged,
        failed, reason if failed else "", warp_path,
    )


class FrameTracker:
    """Turns frame messages into fits, one per frame."""

    def __init__(self, svc: Service, aam: AAM, fitter: Fitter, warp_path: str,
                 detector: ServiceDetector) -> None:
        self.svc = svc
        self.scheme = aam.scheme.name
        self.tracker = Tracker(fitter, detector)
        self.detector = detector
        self.warp_path = warp_path
        self._last_index = -1
        self._size: tuple[int, int] | None = None

    def handle(self, got: Received) -> Fit | None:
        """The fit for one received frame, or None when the frame is rejected."""
        frame = got.message
        assert isinstance(frame, Frame)
        try:
            image = image_of(frame)
        except ProtoError as exc:
            self.svc.reject("frame", exc.reason)
            return None
        if image.ndim == 3 and image.shape[2] != 3:
            self.svc.reject("frame", f"frame with {image.shape[2]} channels")
            return None
        if not self._accept(frame):
            return None
        self.detector.set_frame(image, got.payload if frame.encoding == "raw" else b"")
        result = self.tracker.track(image)
        header = self.svc.header(frame.header.frame_index, frame.header.capture_time_ns)
        return fit_message(header, result, self.scheme, self.warp_path)

    def _accept(self, frame: Frame) -> bool:
        """Check the frame's size against the stream's; forget the face on a new run.

        A frame of another size than the stream's is rejected unless it is
        frame 0, the start of a new run of the source.
        """
        size, index = (frame.width, frame.height), frame.header.frame_index
        if self._size is not None and size != self._size and index != 0:
            self.svc.reject("frame", f"frame {index} is {size[0]} x {size[1]}, the stream's "
                            f"frames are {self._size[0]} x {self._size[1]}")
            return False
        if index <= self._last_index or size != self._size:
            self.tracker.reset()
        self._last_index, self._size = index, size
        return True


def warm_up(fitter: Fitter) -> None:
    """Fit once on a blank frame so that the first real frame pays no set-up costs
    (GL shaders and textures, first-call allocations)."""
    blank = np.full((480, 640, 3), 128, np.uint8)
    try:
        fitter.fit_box(blank, np.array([220.0, 140.0, 200.0, 200.0]))
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
        logging.getLogger("aamtrack.fitter").debug("warm-up fit failed: %s", exc)


def serve(svc: Service, tracker: FrameTracker, capacity: int) -> None:
    """Fit frames until stopped."""
    frames = svc.inbox("frame", capacity=capacity)
    svc.ready(f"warp {tracker.warp_path}")
    while not svc.stopping:
        got = frames.get(timeout=0.5)
        if got is None:
            continue
        started = time.perf_counter()
        fit = tracker.handle(got)
        if fit is not None:
            svc.publish(fit)
            svc.stats.latency.add(1000 * (time.perf_counter() - started))
        svc.set_state("running", f"warp {tracker.warp_path}; {tracker.detector.queries} "
                      f"detector queries, {tracker.detector.local_detections} local detections")


def run(args: argparse.Namespace) -> int:
    """Run the fitter with parsed arguments; the exit code."""
    log = init_process(NAME, args.verbose)
    try:
        model = FittingModel.load(model_path(args))
        warp, warp_path = make_warp(model.aam, args.warp)
    except (OSError, ValueError) as exc:
        log.error("cannot load the model: %s", exc)
        return 1
    log.info("warp on the %s (%s)", warp_path, getattr(warp, "renderer", ""))
    try:
        fitter = Fitter(model, args.algorithm, warp=warp, failure_test=args.failure_test)
        warm_up(fitter)
        with Service(NAME, BusOptions.from_args(args)) as svc:
            detector = ServiceDetector(svc, args.detect_timeout, args.local_for)
            serve(svc, FrameTracker(svc, model.aam, fitter, warp_path, detector), args.capacity)
    finally:
        warp.close()
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point: ``python -m services.fitter.service``."""
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
