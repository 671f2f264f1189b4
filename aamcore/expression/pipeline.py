"""The expression pipeline of one stream: quality gate, features, reference, classifier.

::

    pipeline = ExpressionPipeline(classifier)          # once per stream
    estimate = pipeline.process(observation)           # per frame, in frame order
    # estimate.label is None (with estimate.reason) or a class name with scores

``observation`` is a :class:`~aamcore.expression.crop.FaceObservation` of the
frame and its fit. The training and the benchmark compute their vectors with
the same :func:`~aamcore.expression.analysis.analyse_face` and
:class:`~aamcore.expression.reference.NeutralReference`.
:class:`~aamcore.expression.recogniser.ExpressionRecogniser` adds the score
smoothing and the frame bookkeeping the library and the service share.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aamcore.expression.analysis import analyse_face, feature_vector, hidden_dims
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.crop import FaceFeatureError, FaceObservation
from aamcore.expression.learning import neutral_probability
from aamcore.expression.quality import LEARNING
from aamcore.expression.reference import NeutralReference
from aamcore.expression.spec import PipelineSpec

LOST_FRAMES_RESET = 60
"""Frames in a row without a classifiable face after which the reference is forgotten (the
next face may be another person's): two seconds at 30 fps."""


@dataclass(frozen=True, eq=False)
class ExpressionEstimate:
    """The expression of one frame before smoothing, or why there is none.

    Attributes
    ----------
    label : str or None
        The class of highest score; ``None`` when the face was not classified.
    scores : (n_classes,) float64 array or None
        Per-class probabilities (summing to 1) in the classifier's ``class_names`` order.
    reason : str
        Why there is no label (empty when there is one), ``"<key>: <details>"``.
    reference_count : int
        Vectors in the stream's reference.
    basis : str
        What decided: ``"relative"`` (the features against the stream's reference, fused
        with the person-independent model), ``"absolute"`` (the person-independent model,
        while there is no reference) or empty without a label.
    """

    label: str | None
    scores: np.ndarray | None
    reason: str = ""
    reference_count: int = 0
    basis: str = ""

    @property
    def ok(self) -> bool:
        return self.label is not None


def spec_fill(spec: PipelineSpec) -> int | None:
    """The appearance length a fit without an appearance is filled to (zeros) under ``spec``,
    or None where it is not (its features are the appearance alone, or have none)."""
    blocks = spec.features.blocks
    return spec.appearance_dim if "appearance" in blocks and len(blocks) > 1 else None


class ExpressionPipeline:
    """Classify the faces of one stream.

    Parameters
    ----------
    classifier : ExpressionClassifier
    lost_frames_reset : int
        Forget the reference after this many frames in a row without a
        classifiable face.
    """

    def __init__(
        self, classifier: ExpressionClassifier, lost_frames_reset: int = LOST_FRAMES_RESET
    ) -> None:
        if lost_frames_reset < 1:
            raise ValueError(f"lost_frames_reset must be >= 1, got {lost_frames_reset}")
        self.classifier = classifier
        self.spec = classifier.pipeline
        self.reference: NeutralReference = self.spec.new_reference()
        self.lost_frames_reset = lost_frames_reset
        self._lost = 0
        # A fit without an appearance is zeros beside the image's blocks, as in training; an
        # appearance-only classifier refuses it.
        self._fill = spec_fill(self.spec)

    def reset(self) -> None:
        """Forget the stream's reference (a new stream or another person)."""
        self.reference.reset()
        self._lost = 0

    def _none(self, reason: str) -> ExpressionEstimate:
        self._lost += 1
        if self._lost >= self.lost_frames_reset and self.reference.count:
            self.reference.reset()
        return ExpressionEstimate(None, None, reason, self.reference.count)

    def process(self, observation: FaceObservation) -> ExpressionEstimate:
        """The expression of the next frame of the stream.

        A face the quality gate refuses gets no label, with the reason.
        Otherwise, in a relative pipeline, its feature vector is offered to the
        stream's reference (a running median of the faces the person-independent model
        calls neutral enough); once the reference is ready
        ``vector - reference`` is classified, fused with the person-independent
        model's answer, before that the absolute vector by the person-independent
        model alone (without one, the reason is :data:`~aamcore.expression.quality.LEARNING`).
        """
        spec = self.spec
        try:
            problem, blocks = analyse_face(observation, spec.features, spec.quality,
                                           spec.template, appearance_dim=self._fill)
        except FaceFeatureError as exc:
            return self._none(f"no features: {exc}")
        if problem or blocks is None:
            return self._none(problem)
        vector = feature_vector(blocks, spec.features)
        if vector.shape != (spec.feature_dim,):
            return self._none(
                f"wrong feature length: {vector.size}, the classifier expects "
                f"{spec.feature_dim} (appearance vector of {observation.appearance.size})"
            )
        self._lost = 0
        classifier = self.classifier
        # expression from the visible evidence: the patches of landmarks flagged occluded
        # read as the average face's (the network's mean) and as no change from the
        # person's reference (held out, python -m bench expression-degraded: sharp faces
        # 68.9 -> 70.1 % right, under a hand 56.2 -> 57.1 %; bench expression --streams:
        # 63.1 -> 62.9 % of the frames; all within the benches' noise)
        hidden = hidden_dims(observation.occluded, spec.features, spec.appearance_dim)
        if not spec.relative:
            return self._estimate(classifier.probabilities(
                _average(vector, hidden, classifier.model)[None, :])[0], "absolute")
        absolute = classifier.absolute is not None
        seen = _average(vector, hidden, classifier.absolute) if absolute else vector
        p_abs = classifier.absolute_probabilities(seen[None, :])[0] if absolute else None
        if not hidden.size:  # the reference learns from faces seen whole
            self.reference.update(vector, 1.0 if p_abs is None else
                                  float(neutral_probability(p_abs[None, :],
                                                            classifier.class_names)[0]))
        if self.reference.ready:
            relative = (vector - self.reference.reference())[None, :]
            relative[0, hidden] = 0.0
            p = classifier.fused_probabilities(relative, seen[None, :]) if absolute \
                else classifier.probabilities(relative)
            return self._estimate(p[0], "relative")
        if p_abs is not None:
            return self._estimate(p_abs, "absolute")
        return ExpressionEstimate(None, None, f"{LEARNING}: {self.reference.count} of "
                                  f"{self.reference.min_count} samples", self.reference.count)

    def _estimate(self, probabilities: np.ndarray, basis: str) -> ExpressionEstimate:
        label = self.classifier.class_names[int(np.argmax(probabilities))]
        return ExpressionEstimate(label, probabilities, "", self.reference.count, basis)


def _average(vector: np.ndarray, hidden: np.ndarray, model: object) -> np.ndarray:
    """``vector`` (d,) with its dimensions ``hidden`` set to ``model``'s mean, where the
    model centres its inputs on one (the network, the linear models); as it is otherwise."""
    mean = getattr(model, "mean", None)
    if not hidden.size or mean is None:
        return vector
    seen = vector.copy()
    seen[hidden] = mean[hidden]
    return seen
