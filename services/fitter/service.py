"""The fitter service: a thin adapter around the fit stage's operator
(:class:`aamcore.operators.fit.FitOperator`), one ``Fit`` per face of each frame.

``aamtrack service fitter [--model FILE] [--algorithm NAME] [--warp gpu|cpu]``

Faces are searched for by asking the detector service (a Zenoh query on
``aamtrack/<stream>/detect`` carrying the frame); if it does not answer within
``--detect-timeout`` seconds, the fitter detects locally for ``--local-for`` seconds
(logged), then asks again. Every frame taken gets its fits: one per face tracked, or one
without a face (``failed``, the reason, a failed fit's landmarks or none). Every good fit
carries the AAM's appearance (``--no-appearance`` leaves it out); each names the path its
warps took in ``warp_path``, and the status counts the warps per path. A new run starts
afresh; a frame of another size than its run's first is rejected.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np

from aamcore.fitting.model import FittingModel
from aamcore.fitting.result import AAMFit
from aamcore.model.file import ModelFileError
from aamcore.operators.faces import FaceFit, FrameRef
from aamcore.operators.fit import FitOperator
from aamcore.profiles import model_path
from aamcore.warp.reference_frame import ReferenceFrame
from proto import Fit, FitAppearance, Frame, Header, ProtoError
from services.bus.args import parse_service_args
from services.bus.images import image_of
from services.bus.process import init_process
from services.bus.session import Service
from services.fitter.detector_client import ServiceDetector
from services.fitter.options import FitterOptions

NAME = "fitter"
EMPTY_POINTS = np.zeros((0, 2), np.float32)
EMPTY = np.zeros(0, np.float32)


def fit_message(header: Header, face: FaceFit, warp_path: str, size: tuple[int, int],
                frame: ReferenceFrame | None = None, faces: int = 1) -> Fit:
    """The ``Fit`` message of one face's fit on a frame of ``size``, its warps on
    ``warp_path``; ``frame`` lays an appearance's residual out as an image, ``faces`` is how
    many fits the frame has."""
    result = face.fit
    if result is None:
        return Fit(header, face.scheme, EMPTY_POINTS, EMPTY, *size, True, face.reason, 0.0,
                   warp_path, None, face.face_id, faces)
    sim = result.similarity
    similarity = np.array([sim.a, sim.b, sim.tx, sim.ty])
    finite = bool(np.all(np.isfinite(face.points)) and np.all(np.isfinite(similarity)))
    appearance = appearance_of(result, frame) if finite else None
    failed = bool(result.failed or not finite)
    reason = result.reason or ("non-finite result" if not finite else "")
    confidence = 0.0 if failed or not math.isfinite(result.confidence) else result.confidence
    return Fit(header, face.scheme,
               face.points.astype(np.float32) if finite else EMPTY_POINTS,
               similarity.astype(np.float32) if finite else EMPTY,
               *size, failed, reason if failed else "", float(confidence),
               warp_path if appearance is not None or warp_path != "none" else "none",
               appearance, -1 if failed else face.face_id, faces)


def appearance_of(result: object, frame: ReferenceFrame | None) -> FitAppearance | None:
    """The ``appearance`` of a fit's message: None for a fit without one (or with a
    non-finite one)."""
    if not isinstance(result, AAMFit) or frame is None:
        return None
    if not (np.all(np.isfinite(result.c)) and np.all(np.isfinite(result.residual))
            and math.isfinite(result.error)):
        return None
    occluded = (np.zeros(0, np.uint8) if result.occluded is None
                else result.occluded.astype(np.uint8))
    return FitAppearance(result.c.astype(np.float32),
                         frame.to_image(result.residual.astype(np.float32)),
                         max(float(result.error), 0.0), int(result.iterations),
                         bool(result.converged), occluded)


def warm_up(op: FitOperator) -> None:
    """Fit once on a blank frame, and warp it once where the fitter warps, so that the
    first real frame pays no set-up costs (the GL context, shaders and textures,
    first-call allocations); the warm-up's warps are not counted."""
    fitter, warp = op.fitter, op.warp
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


def serve(svc: Service, op: FitOperator, opts: FitterOptions) -> None:
    """Fit frames until stopped: receive, call the operator, publish."""
    detector = ServiceDetector(svc, opts.detect_timeout, opts.local_for)
    op.search_with(detector)
    run: tuple[str | None, tuple[int, int]] = (None, (0, 0))
    warp, name = op.warp, op.fitter.name
    svc.ready(f"{name}, warp {warp.path}")
    for got in svc.messages("frame", capacity=opts.capacity, count_lost=True):
        frame = got.message
        assert isinstance(frame, Frame)
        h, size = frame.header, (frame.width, frame.height)
        if h.run_id != run[0]:
            run = (h.run_id, size)
            op.reset()
        elif size != run[1]:
            svc.reject("frame", f"frame {h.frame_index} is {size[0]} x {size[1]}, the frames "
                       f"of run {run[0]!r} are {run[1][0]} x {run[1][1]}")
            continue
        try:
            image = image_of(frame)
        except ProtoError as exc:
            svc.reject("frame", exc.reason)
            continue
        detector.set_frame(image, got.payload, h)
        faces = op(image, FrameRef(h.frame_index, h.media_time_ns / 1e9, *size))
        header = svc.header_for(frame)
        for face in faces:
            svc.publish(fit_message(header, face, op.warp_path, size, op.fitter.aam.frame,
                                    len(faces)))
        svc.set_state("running", f"{name}, warp {warp.path}; {warp.summary()}; "
                      f"{detector.queries} detector queries, {detector.local_detections} "
                      "local detections")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.fitter.service``."""
    args = parse_service_args(NAME, "Fit the AAM to each frame and publish the fits.",
                              FitterOptions, argv)
    log = init_process(NAME, args.verbose)
    opts: FitterOptions = args.options
    try:
        op = FitOperator(FittingModel.load(model_path(opts.model)), opts.fit)
    except (OSError, ValueError, ModelFileError) as exc:
        log.error("cannot load the model: %s", exc)
        return 1
    try:
        warm_up(op)
        log.info("warp on the %s (%s)", op.warp.path, op.warp.renderer or "nothing warps")
        with Service(NAME, args.bus) as svc:
            serve(svc, op, opts)
    finally:
        op.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
