"""The expression service: classifies the appearance vector of each good fit.

``aamtrack service expression --classifier FILE [--model FILE] [--smooth N]``

Each fit that did not fail is classified by the
:class:`~aamcore.expression.ExpressionClassifier`; with ``--smooth N`` the
scores are averaged over the last N good fits (a failed fit or a lost face
starts the average again) and the message says so. Without a usable
classifier (none given, unreadable, or trained for another model) the service
still runs: it takes fits, publishes no expression and says why in its status
(state ``degraded``); so it does for fits without an appearance vector (a
fitter method that computes none, run without ``--appearance``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aamcore.expression import AAMMismatchError, ClassifierFileError, ExpressionClassifier
from aamcore.expression.recogniser import ExpressionRecogniser
from aamcore.expression.training import model_fingerprint
from proto import Expression, Fit
from services.bus.args import parse_service_args
from services.bus.process import init_process
from services.bus.session import Service
from services.expression.options import ExpressionOptions

NAME = "expression"


def load_classifier(path: str | None, model: str | None) -> tuple[ExpressionClassifier | None, str]:
    """The classifier, or ``None`` and why there is none."""
    if not path:
        return None, "no expression classifier given (--classifier)"
    try:
        classifier = ExpressionClassifier.load(path)
        if model:
            classifier.check_aam(model_fingerprint(model))
    except (ClassifierFileError, AAMMismatchError, OSError) as exc:
        return None, f"no expression classifier: {exc}"
    return classifier, ""


def expression_message(svc: Service, fit: Fit, recogniser: ExpressionRecogniser) -> Expression:
    """The expression of one good fit.

    Raises
    ------
    ValueError
        For an appearance vector of another length, or a non-finite one.
    """
    found = recogniser.recognise(fit.header.frame_index, np.asarray(fit.appearance))
    return Expression(svc.header_for(fit), found.label, found.class_names,
                      found.scores.astype(np.float32), found.smoothed)


def serve(svc: Service, classifier: ExpressionClassifier | None, why: str,
          opts: ExpressionOptions) -> None:
    """Classify fits until stopped."""
    recogniser = ExpressionRecogniser(classifier, opts.smooth) if classifier else None
    fits = svc.messages("fit", capacity=opts.capacity)
    if classifier is None:
        svc.log.error("%s; running without expressions", why)
        svc.ready()
        svc.set_state("degraded", why)
    else:
        svc.ready(f"{classifier.kind}, classes {','.join(classifier.class_names)}")
    without = 0
    for got in fits:
        fit = got.message
        assert isinstance(fit, Fit)
        if recogniser is None or fit.failed:
            continue
        if len(fit.appearance) == 0:  # the fitter's method samples none unless asked
            without += 1
            if without == 1:
                svc.set_state("degraded", "fits carry no appearance vector: start the fitter "
                              "with --appearance (local-binary samples none without it)")
            continue
        try:
            message = expression_message(svc, fit, recogniser)
        except ValueError as exc:  # an appearance vector of another length or non-finite
            svc.reject("fit", f"not classified: {exc}")
            continue
        svc.publish(message)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``python -m services.expression.service``."""
    args = parse_service_args(NAME, "Facial expression of each good fit.", ExpressionOptions,
                              argv)
    init_process(NAME, args.verbose)
    classifier, why = load_classifier(args.options.classifier, args.options.model)
    with Service(NAME, args.bus) as svc:
        serve(svc, classifier, why, args.options)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
