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
the reason), or ``failed`` with reason ``no face`` and no landmarks. Every
good fit carries the AAM's appearance (``c``, the per-pixel texture residual,
the texture error, per-landmark occlusion flags): with the default method
(``local-binary``, a landmark regressor) the face is sampled into the AAM's
reference frame after the landmarks and projected (``--no-appearance`` leaves
it out: nothing is warped). The warps run on the GPU worker thread
(:mod:`aamcore.warp.worker`, started only for a fitter that warps) or the
CPU (:mod:`aamcore.fitting.warps`); each fit names the path its warps took in
``warp_path`` (``none`` when nothing was warped), and the status counts the
warps and their time per path. A frame's size belongs to its run: a new run
starts the tracking afresh, and a frame of another size than its run's first
is rejected.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.multi import MultiTracker
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.fitting.warps import FitterWarp
from aamcore.model.file import ModelFileError
from aamcore.profiles import PROFILES
from aamcore.smoothing import LandmarkSmoother
from aamcore.tracker_config import TrackerConfig
from aamcore.warp.reference_frame import ReferenceFrame
from proto import Fit, FitAppearance, Frame, Header, ProtoError
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
EMPTY_FLAGS = np.zeros(0, np.uint8)


def model_path(opts: FitterOptions) -> Path:
    """The model file to use: ``--model`` or the cached default (trained if needed)."""
    if opts.model:
        return Path(opts.model)
    return PROFILES["default"].model_path(opts.model_images, opts.model_limit or None,
                                          opts.model_update)


def fit_message(header: Header, result: LandmarkFit | None, scheme: str, warp_path: str,
                size: tuple[int, int], frame: ReferenceFrame | None = None,
                face_id: int = 0, faces: int = 1) -> Fit:
    """The ``Fit`` message of a tracking result (``None``: no face found) on a frame of ``size``,
    its warps on ``warp_path``; ``frame`` lays an appearance's residual out as an image.
    ``face_id`` is the face's (-1 for a failed fit), ``faces`` how many fits the frame has."""
    width, height = size
    if result is None:
        return Fit(header, scheme, EMPTY_POINTS, EMPTY, width, height, True, NO_FACE, 0.0,
                   warp_path, None, -1, 1)
    sim = result.similarity
    similarity = np.array([sim.a, sim.b, sim.tx, sim.ty])
    finite = bool(np.all(np.isfinite(result.points)) and np.all(np.isfinite(similarity)))
    appearance = appearance_of(result, frame) if finite else None
    reason = result.reason or ("non-finite result" if not finite else "")
    failed = bool(result.failed or not finite)
    confidence = 0.0 if failed or not math.isfinite(result.confidence) else result.confidence
    return Fit(
        header, scheme,
        result.points.astype(np.float32) if finite else EMPTY_POINTS,
        similarity.astype(np.float32) if finite else EMPTY,
        width, height, failed, reason if failed else "", float(confidence),
        warp_path if appearance is not None or warp_path != "none" else "none",
        appearance, -1 if failed else face_id, faces,
    )


def appearance_of(result: LandmarkFit, frame: ReferenceFrame | None) -> FitAppearance | None:
    """The ``appearance`` of a fit's message: None for a fit without one (or with a
    non-finite one)."""
    if not isinstance(result, AAMFit) or frame is None:
        return None
    if not (np.all(np.isfinite(result.c)) and np.all(np.isfinite(result.residual))
            and math.isfinite(result.error)):
        return None
    occluded = EMPTY_FLAGS if result.occluded is None else result.occluded.astype(np.uint8)
    return FitAppearance(result.c.astype(np.float32),
                         frame.to_image(result.residual.astype(np.float32)),
                         max(float(result.error), 0.0), int(result.iterations),
                         bool(result.converged), occluded)


class FrameTracker:
    """Turns frame messages into fits, one per face tracked or one without a face (landmarks
    smoothed per face if asked, as :class:`aamcore.tracker.FaceTracker` smooths them)."""

    def __init__(self, svc: Service, fitter: Fitter, warp: FitterWarp,
                 detector: ServiceDetector, config: TrackerConfig) -> None:
        self.svc = svc
        self.scheme = fitter.aam.scheme.name
        self.frame = fitter.aam.frame
        self.tracker = MultiTracker.configured(fitter, config, detector)
        self.detector = detector
        self.warp = warp
        self.smooth = config.smoothing
        self.smoothers: dict[int, LandmarkSmoother] = {}
        """Per face (with one face, the one smoother whatever its id, as the library's)."""
        self._run: str | None = None
        self._size: tuple[int, int] = (0, 0)
        self._last_index = -1

    def handle(self, got: Received) -> list[Fit]:
        """The fits of one received frame (none when the frame is rejected)."""
        frame = got.message
        assert isinstance(frame, Frame)
        if not self._accept(frame):
            return []
        try:
            image = image_of(frame)
        except ProtoError as exc:
            self.svc.reject("frame", exc.reason)
            return []
        self.detector.set_frame(image, got.payload, got.message.header)
        self.warp.take_path()
        tracked, failed = self.tracker.track(image)
        warp_path = self.warp.take_path()
        header, t = self.svc.header_for(frame), frame.header.media_time_ns / 1e9
        if not tracked:
            for smoother in self.smoothers.values():
                smoother.reset()
            result = failed if failed is None or not self.smooth else self._smoother(-1).smoothed(
                failed, t)
            return [fit_message(header, result, self.scheme, warp_path, self._size, self.frame)]
        fits = []
        for face in tracked:
            result = face.fit if not self.smooth else self._smoother(face.face_id).smoothed(
                face.fit, t)
            fits.append(fit_message(header, result, self.scheme, warp_path, self._size,
                                    self.frame, face.face_id, len(tracked)))
        here = {face.face_id for face in tracked}
        if self.tracker.max_faces > 1:
            for gone in [k for k in self.smoothers if k not in here]:
                del self.smoothers[gone]
        return fits

    def _smoother(self, face_id: int) -> LandmarkSmoother:
        key = face_id if self.tracker.max_faces > 1 else 0
        if key not in self.smoothers:
            self.smoothers[key] = LandmarkSmoother()
        return self.smoothers[key]

    def reset(self) -> None:
        self.tracker.reset()
        self.smoothers.clear()

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


def warm_up(fitter: Fitter, warp: FitterWarp) -> None:
    """Fit once on a blank frame, and warp it once where the fitter warps, so that the
    first real frame pays no set-up costs (the GL context, shaders and textures,
    first-call allocations); the warm-up's warps are not counted."""
    blank = np.full((480, 640, 3), 128, np.uint8)
    box = np.array([220.0, 140.0, 200.0, 200.0])
    try:
        if fitter.warps:
            warp.start()
            start = fitter.mapping.place(box, "detector")
            warp.warp(fitter.aam.prepare_image(blank, start), start)
        fitter.fit_box(blank, box)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
        logging.getLogger("aamtrack.fitter").debug("warm-up fit failed: %s", exc)
    warp.counts = dict.fromkeys(warp.counts, 0)
    warp.seconds = dict.fromkeys(warp.seconds, 0.0)
    warp.take_path()


def serve(svc: Service, fitter: Fitter, warp: FitterWarp, opts: FitterOptions) -> None:
    """Fit frames until stopped."""
    detector = ServiceDetector(svc, opts.detect_timeout, opts.local_for)
    tracker = FrameTracker(svc, fitter, warp, detector, opts.tracking)
    frames = svc.messages("frame", capacity=opts.capacity, count_lost=True)
    svc.ready(f"{fitter.name}, warp {warp.path}")
    for got in frames:
        for fit in tracker.handle(got):
            svc.publish(fit)
        svc.set_state("running", f"{fitter.name}, warp {warp.path}; {warp.summary()}; "
                      f"{detector.queries} detector queries, {detector.local_detections} "
                      "local detections")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.fitter.service``."""
    args = parse_service_args(NAME, "Fit the AAM to each frame and publish the fits.",
                              FitterOptions, argv)
    log = init_process(NAME, args.verbose)
    opts: FitterOptions = args.options
    try:
        model = FittingModel.load(model_path(opts))
        warp = FitterWarp(model.aam, opts.tracking.warp)  # type: ignore[arg-type]
        fitter = Fitter(model, opts.tracking.fitting, warp)
    except (OSError, ValueError, ModelFileError) as exc:
        log.error("cannot load the model: %s", exc)
        return 1
    try:
        warm_up(fitter, warp)
        log.info("warp on the %s (%s)", warp.path, warp.renderer or "nothing warps")
        with Service(NAME, args.bus) as svc:
            serve(svc, fitter, warp, opts)
    finally:
        warp.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
