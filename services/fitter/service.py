"""The fitter service: tracks the face from frame to frame and publishes one fit per frame.

``aamtrack service fitter [--model FILE] [--algorithm NAME] [--warp gpu|cpu]``

Each frame is fitted from the previous frame's fit; when there is no face
yet or that fit fails, the fitter asks the detector service (a Zenoh query on
``aamtrack/<stream>/detect`` carrying the frame) and fits from the box it
returns, as :class:`aamcore.fitting.tracker.Tracker` does with a local
detector. If the detector service does not answer within ``--detect-timeout``
seconds, the fitter detects locally for ``--local-for`` seconds (logged) and
then asks the service again.

Every frame taken gets a ``Fit``: a good one, a failed one (``failed`` with
the reason), or ``failed`` with reason ``no face`` and no landmarks. With the
default method (``local-binary``) the appearance is sampled only with
``--appearance`` (the default; the stack turns it off when no expression is
classified), else the fit carries an empty one. The warp
runs on the GPU worker thread (:mod:`aamcore.warp.worker`) or the CPU; each
fit names the path in ``warp_path``. A frame's size belongs to its run: a new
run starts the tracking afresh, and a frame of another size than its run's
first is rejected.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.result import FitResult
from aamcore.fitting.tracker import Tracker
from aamcore.fitting.training.prepare import default_model_path
from aamcore.model.file import ModelFileError
from aamcore.smoothing import LandmarkSmoother
from aamcore.warp.worker import make_warp
from proto import Fit, Frame, Header, ProtoError
from services.bus.args import parse_service_args
from services.bus.images import image_of
from services.bus.inbox import Received
from services.bus.process import init_process
from services.bus.session import Service
from services.fitter.detector_client import ServiceDetector
from services.fitter.options import FitterOptions

NAME = "fitter"
NO_FACE = "no face"
EMPTY_POINTS = np.zeros((0, 2), np.float32)
EMPTY = np.zeros(0, np.float32)


def model_path(opts: FitterOptions) -> Path:
    """The model file to use: ``--model`` or the cached default (trained if needed)."""
    if opts.model:
        return Path(opts.model)
    return default_model_path(max_images=opts.model_images, limit=opts.model_limit or None)


def fit_message(header: Header, result: FitResult | None, scheme: str, warp_path: str,
                size: tuple[int, int]) -> Fit:
    """The ``Fit`` message of a tracking result (``None``: no face found) on a frame of ``size``."""
    width, height = size
    if result is None:
        return Fit(header, scheme, EMPTY_POINTS, EMPTY, EMPTY, width, height, math.nan, 0,
                   False, True, NO_FACE, warp_path, 0.0)
    sim = result.similarity
    similarity = np.array([sim.a, sim.b, sim.tx, sim.ty])
    finite = bool(np.all(np.isfinite(result.points)) and np.all(np.isfinite(result.c))
                  and np.all(np.isfinite(similarity)))
    error = float(result.error) if math.isfinite(result.error) else math.nan
    reason = result.reason or ("non-finite result" if not finite else "")
    failed = bool(result.failed or not finite)
    return Fit(
        header, scheme,
        result.points.astype(np.float32) if finite else EMPTY_POINTS,
        result.c.astype(np.float32) if finite else EMPTY,
        similarity.astype(np.float32) if finite else EMPTY,
        width, height,
        max(error, 0.0) if not math.isnan(error) else error,
        int(result.iterations),
        not failed and result.converged,
        failed, reason if failed else "", warp_path,
        0.0 if failed or not math.isfinite(result.confidence) else float(result.confidence),
    )


class FrameTracker:
    """Turns frame messages into fits, one per frame (landmarks smoothed if asked, as
    :meth:`aamcore.tracker.FaceTracker.smooth_landmarks` does)."""

    def __init__(self, svc: Service, fitter: Fitter, warp_path: str,
                 detector: ServiceDetector, smooth: bool) -> None:
        self.svc = svc
        self.scheme = fitter.aam.scheme.name
        self.tracker = Tracker(fitter, detector)
        self.detector = detector
        self.warp_path = warp_path
        self.smoother = LandmarkSmoother() if smooth else None
        self._run: str | None = None
        self._size: tuple[int, int] = (0, 0)
        self._last_index = -1

    def handle(self, got: Received) -> Fit | None:
        """The fit for one received frame, or None when the frame is rejected."""
        frame = got.message
        assert isinstance(frame, Frame)
        if not self._accept(frame):
            return None
        try:
            image = image_of(frame)
        except ProtoError as exc:
            self.svc.reject("frame", exc.reason)
            return None
        self.detector.set_frame(image, got.payload)
        result = self.tracker.track(image)
        if self.smoother is not None:
            if result is None:
                self.smoother.reset()
            else:
                t = frame.header.media_time_ns / 1e9
                # A copy: the tracker goes on from the raw fit, as the library's does.
                result = replace(result, points=self.smoother.update(result.points, t, result.ok))
        return fit_message(self.svc.header_for(frame), result, self.scheme, self.warp_path,
                           self._size)

    def reset(self) -> None:
        self.tracker.reset()
        if self.smoother is not None:
            self.smoother.reset()

    def _accept(self, frame: Frame) -> bool:
        """A new run starts afresh with its own frame size; within a run, sizes must agree."""
        size, header = (frame.width, frame.height), frame.header
        if header.run_id != self._run:
            self._run, self._size, self._last_index = header.run_id, size, -1
            self.reset()
        elif size != self._size:
            self.svc.reject("frame", f"frame {header.frame_index} is {size[0]} x {size[1]}, the "
                            f"frames of run {self._run!r} are {self._size[0]} x {self._size[1]}")
            return False
        if header.frame_index <= self._last_index:
            self.reset()  # the source went back: the last fit is not this frame's past
        self._last_index = header.frame_index
        return True


def warm_up(fitter: Fitter) -> None:
    """Fit once on a blank frame so that the first real frame pays no set-up costs
    (GL shaders and textures, first-call allocations)."""
    blank = np.full((480, 640, 3), 128, np.uint8)
    try:
        fitter.fit_box(blank, np.array([220.0, 140.0, 200.0, 200.0]))
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
        logging.getLogger("aamtrack.fitter").debug("warm-up fit failed: %s", exc)


def serve(svc: Service, fitter: Fitter, warp_path: str, opts: FitterOptions) -> None:
    """Fit frames until stopped."""
    detector = ServiceDetector(svc, opts.detect_timeout, opts.local_for)
    tracker = FrameTracker(svc, fitter, warp_path, detector, opts.smooth)
    frames = svc.messages("frame", capacity=opts.capacity, count_lost=True)
    svc.ready(f"{fitter.name}, warp {warp_path}")
    for got in frames:
        fit = tracker.handle(got)
        if fit is not None:
            svc.publish(fit)
        svc.set_state("running", f"{fitter.name}, warp {warp_path}; {detector.queries} "
                      f"detector queries, {detector.local_detections} local detections")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.fitter.service``."""
    args = parse_service_args(NAME, "Fit the AAM to each frame and publish the fits.",
                              FitterOptions, argv)
    log = init_process(NAME, args.verbose)
    opts: FitterOptions = args.options
    try:
        model = FittingModel.load(model_path(opts))
        fitter_warp, warp_path = make_warp(model.aam, opts.warp)
    except (OSError, ValueError, ModelFileError) as exc:
        log.error("cannot load the model: %s", exc)
        return 1
    log.info("warp on the %s (%s)", warp_path, getattr(fitter_warp, "renderer", ""))
    try:
        fitter = Fitter(model, opts.algorithm, warp=fitter_warp, failure_test=opts.failure_test,
                        appearance=opts.appearance)
        warm_up(fitter)
        with Service(NAME, args.bus) as svc:
            serve(svc, fitter, warp_path, opts)
    finally:
        fitter_warp.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
