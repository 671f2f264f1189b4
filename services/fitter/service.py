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

from collections.abc import Sequence

from aamcore.fitting.model import FittingModel
from aamcore.model.file import ModelFileError
from aamcore.operators.faces import FrameRef
from aamcore.operators.fit import FitOperator
from aamcore.profiles import model_path
from proto import Frame, ProtoError
from services.bus.args import parse_service_args
from services.bus.images import image_of
from services.bus.process import init_process
from services.bus.session import Service
from services.detector.client import ServiceDetector
from services.fitter.options import FitterOptions
from services.messages import fit_message

NAME = "fitter"


def serve(svc: Service, op: FitOperator, opts: FitterOptions) -> None:
    """Fit frames until stopped: receive, call the operator, publish."""
    detector = ServiceDetector(svc, opts.detect_timeout, opts.local_for)
    op.search_with(detector)
    run: tuple[str | None, tuple[int, int]] = (None, (0, 0))
    warp, name = op.warp, op.fitter.name
    frames = svc.messages("frame", capacity=opts.capacity, count_lost=True)  # before ready()
    svc.ready(f"{name}, warp {warp.path}")
    for got in frames:
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
        op.warm_up()
        log.info("warp on the %s (%s)", op.warp.path, op.warp.renderer or "nothing warps")
        with Service(NAME, args.bus) as svc:
            serve(svc, op, opts)
    finally:
        op.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
