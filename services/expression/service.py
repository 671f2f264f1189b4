"""The expression service: a thin adapter around the expression stage's operator
(:class:`aamcore.operators.expression.ExpressionOperator`), an ``Expression`` for each fit.

``aamtrack service expression --classifier FILE [--model FILE] [--expression-average N]``

For every fit the service takes the frame it was made on (the latest frames are kept by
frame index, :meth:`~services.bus.receiving.Receiving.recent`) and hands both to the
operator, as :class:`aamcore.tracker.FaceTracker` does with the frames it tracks. A fit
without expression (no face, a face the gate refuses, the reference still being learned)
gets an expression with an empty label and the reason; the status line counts each
reason. A new run, or a frame index that goes back, starts afresh.

Without a usable classifier (none given, unreadable, of another format or feature
version, made for another fitting model) the service still runs: it answers each fit with
no label and the reason, and says why in its status (state ``degraded``); so it does when
fits of another landmark scheme or AAM arrive.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from aamcore.expression import AAMMismatchError, ClassifierFileError, ExpressionClassifier
from aamcore.expression.crop import grey as crop_grey
from aamcore.operators.expression import ExpressionOperator
from aamcore.operators.expression import load_classifier as checked_classifier
from proto import Expression, Fit, Frame, ProtoError
from services.bus.args import parse_service_args
from services.bus.images import image_of
from services.bus.inbox import Received, Recent
from services.bus.process import init_process
from services.bus.session import Service
from services.bus.stats import ReasonCounts
from services.expression.options import ExpressionOptions
from services.messages import expression_message, face_of, frame_of, unlabelled

NAME = "expression"
FRAMES_KEPT = 64
"""Frames kept for the fits still to come: more than the fit backlog, so that a fit waiting
in it still finds its frame, up to :data:`MAX_FRAMES_KEPT`."""
MAX_FRAMES_KEPT = 256
"""At most this many, kept grey (all the pipeline reads): 59 MB of 640 x 360 frames, 236 MB
of 1280 x 720. A fast-paced run keeps 1,024 fits while busy; before this bound it kept a
frame for each, raw and decoded (1.4 MB each): 1.6 GB. A fit whose frame was pushed out is
counted as dropped (``no frame``)."""
FRAME_WAIT_S = 0.5
"""How long a fit waits for its frame: the source's frame and the fitter's fit travel apart."""


def load_classifier(path: str | None, model: str | None, algorithm: str | None = None
                    ) -> tuple[ExpressionClassifier | None, str]:
    """The classifier (:func:`aamcore.operators.expression.load_classifier`), or ``None``
    and why there is none."""
    if not path:
        return None, "no expression classifier given (--classifier)"
    try:
        return checked_classifier(path, model, algorithm), ""
    except (ClassifierFileError, AAMMismatchError, OSError) as exc:
        return None, f"no expression classifier: {exc}"


class Unclassified(ReasonCounts):
    """The status line's counts of the fits without expression, by the key of their reason."""

    def status(self) -> str:
        """``"5 fits without expression: 3 no face, 2 face in profile; last: frame 9: ..."``"""
        if not self.total():
            return "every fit with an expression"
        return f"{self.total()} fits without expression: {self.line()}; last {self.last}"


def grey_frame(got: Received) -> Received:
    """What the service keeps of a frame: its header and grey pixels, no encoded bytes."""
    frame = got.message
    assert isinstance(frame, Frame)
    try:
        kept = Frame.from_array(frame.header, crop_grey(image_of(frame)))
    except ProtoError:
        return got  # a frame that does not decode: refused, with its reason, when its fit comes
    return replace(got, message=kept, payload=b"")


def answer(svc: Service, op: ExpressionOperator, fit: Fit, frames: Recent,
           unclassified: Unclassified) -> Expression:
    """The expression of a fit and its frame: a label, or none and why (counted; rejected
    when the fit is unusable)."""
    h = fit.header
    wait = FRAME_WAIT_S if len(fit.landmarks) else 0.0
    frame = frames.take(h.run_id, h.frame_index, timeout=wait, keep=fit.faces > 1)
    if frame is None and len(fit.landmarks):
        svc.stats.dropped += 1  # its frame is gone: never received or pushed out
        reason = "no frame: it was not received in time"
        unclassified.add(reason, h.frame_index)
        return unlabelled(svc, fit, reason, op.class_names)
    try:
        image = image_of(frame.message) if frame is not None else np.zeros((1, 1), np.uint8)
        [found] = op(frame_of(fit), image, [face_of(fit)])
    except AAMMismatchError as exc:
        svc.reject("fit", f"not classified: {exc}")
        svc.set_state("degraded", str(exc))
        return unlabelled(svc, fit, f"not classified: {exc}")
    except (ProtoError, ValueError) as exc:
        svc.reject("fit", f"not classified: {exc}")
        return unlabelled(svc, fit, f"not classified: {exc}")
    if not found.ok:
        unclassified.add(found.reason, h.frame_index)
    return expression_message(svc, fit, found)


def serve(svc: Service, classifier: ExpressionClassifier | None, why: str,
          opts: ExpressionOptions) -> None:
    """Classify fits until stopped: receive a fit, take its frame, call the operator,
    publish."""
    fits = svc.messages("fit", capacity=opts.capacity)  # subscribed before ready()
    if classifier is not None:
        frames = svc.recent("frame", min(max(FRAMES_KEPT, opts.capacity + 16), MAX_FRAMES_KEPT),
                            grey_frame)
        op = ExpressionOperator(classifier, opts.expression, opts.new_faces.forget_frames)
        svc.ready(f"{classifier.kind}, classes {','.join(classifier.class_names)}")
    else:
        svc.log.error("%s; running without expressions", why)
        svc.set_state("degraded", why)  # before ready(): its first status says so
        svc.ready()
    unclassified, run = Unclassified(), None
    for got in fits:
        fit = got.message
        assert isinstance(fit, Fit)
        if classifier is None:
            svc.publish(unlabelled(svc, fit, f"no classifier: {why}"))
            continue
        if fit.header.run_id != run:
            run = fit.header.run_id
            op.reset()
        svc.publish(answer(svc, op, fit, frames, unclassified))
        if svc.state != "degraded":
            svc.set_state("running", unclassified.status())


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.expression.service``."""
    args = parse_service_args(NAME, "Facial expression of each fit, from the fit and its frame.",
                              ExpressionOptions, argv)
    init_process(NAME, args.verbose)
    opts: ExpressionOptions = args.options
    classifier, why = load_classifier(opts.expression.classifier, opts.fitting_model,
                                      opts.algorithm)
    with Service(NAME, args.bus) as svc:
        serve(svc, classifier, why, args.options)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
