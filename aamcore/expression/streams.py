"""Stream-order JAFFE sequences: does the expression hold whatever the stream opens on?

JAFFE's protocol gives each poser a reference made of all their images, close
to neutral; a real stream may open crying or laughing. Here each held-out
poser's images become streams, one per opening expression: the images of
that class first (each held :data:`OPENING_HOLD` frames), then the other
classes' (each held :data:`HOLD` frames), every frame moved by a pixel or two
and given sensor noise. Each stream runs through
:class:`~aamcore.expression.recogniser.ExpressionRecogniser`, the code the
library's :class:`~aamcore.tracker.FaceTracker` and the expression service run
after the fit, with a classifier trained leave-one-poser-out (the held-out
poser's faces never trained on nor calibrated with). The JAFFE images are
fitted once each, as the stack fits a frame; a frame's landmarks are those of
its image, moved with it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from aamcore.expression.calibration import reliability
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.crop import FaceObservation
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.recogniser import ExpressionRecogniser
from aamcore.expression.training import DeployedModels, JaffeFaces, train_deployed

OPENING_HOLD = 30
"""Frames each image of the opening expression is held (three images: three seconds)."""
HOLD = 8
"""Frames each later image is held."""
SHIFT_PX = 2
"""Largest shift of a frame (and its landmarks), pixels."""
NOISE = 3.0
"""Standard deviation of the grey-level noise added to every frame."""


@dataclass(frozen=True)
class StreamRow:
    """One way of reading a stream, built from a fold's trained models.

    Attributes
    ----------
    name : str
    make : callable
        ``make(models) -> (classifier, hold)``.
    neutral_reference : bool
        The models' relative classifier trained against each poser's neutral faces
        (:func:`~aamcore.expression.training.train_deployed`).
    """

    name: str
    make: Callable[[DeployedModels], tuple[ExpressionClassifier, int]]
    neutral_reference: bool = False


def _deployed(gate: float | None = None, hold: int = 0,
              reference: dict[str, int] | None = None
              ) -> Callable[[DeployedModels], tuple[ExpressionClassifier, int]]:
    def make(models: DeployedModels) -> tuple[ExpressionClassifier, int]:
        classifier = models.classifier("bench")
        pipeline = classifier.pipeline
        if gate is not None:
            pipeline = replace(pipeline, neutral_gate=gate)
        if reference is not None:
            pipeline = replace(pipeline, reference=dict(reference))
        return replace(classifier, pipeline=pipeline), hold
    return make


def _running_median(models: DeployedModels) -> tuple[ExpressionClassifier, int]:
    """The pipeline before: every frame enters the reference, nothing decides before it."""
    classifier = models.classifier("bench")
    return replace(classifier, absolute=None,
                   pipeline=replace(classifier.pipeline, neutral_gate=0.0)), 0


def _absolute(models: DeployedModels) -> tuple[ExpressionClassifier, int]:
    """The person-independent model alone: no reference at all."""
    classifier = models.classifier("bench")
    assert classifier.absolute is not None
    return replace(classifier, model=classifier.absolute, absolute=None,
                   temperature=classifier.absolute_temperature,
                   pipeline=replace(classifier.pipeline, relative=False)), 0


def stream_rows(stack_hold: int) -> list[StreamRow]:
    """The rows of the stream benchmark: the deployed pipeline (with the stack's label hold
    too), the running median of every frame (before), the person-independent model alone,
    and the deployed pipeline with other neutral gates."""
    return [
        StreamRow("deployed (neutral-gated reference, person-independent until then)",
                  _deployed()),
        StreamRow(f"deployed + label hold {stack_hold} (the stack)", _deployed(hold=stack_hold)),
        StreamRow("running median of every frame (before)", _running_median),
        StreamRow("person-independent only (no reference)", _absolute),
        StreamRow("deployed, neutral gate 0.3", _deployed(0.3)),
        StreamRow("deployed, neutral gate 0.7", _deployed(0.7)),
        StreamRow("deployed, relative trained on neutral references", _deployed(),
                  neutral_reference=True),
        StreamRow("deployed, relative trained on neutral references + label hold "
                  f"{stack_hold}", _deployed(hold=stack_hold), neutral_reference=True),
        StreamRow("deployed, neutral references, reference ready after 4 of every 2nd frame",
                  _deployed(reference={"window": 120, "stride": 2, "min_count": 4}),
                  neutral_reference=True),
    ]


def stream_order(faces: JaffeFaces, poser: str, opening: str) -> list[int]:
    """The image of each frame of ``poser``'s stream opening on ``opening``."""
    labels = faces.labels.astype(str)
    mine = faces.posers.astype(str) == poser
    order = list(SEVEN_CLASSES)
    order = order[order.index(opening):] + order[:order.index(opening)]
    frames: list[int] = []
    for k, name in enumerate(order):
        for i in np.flatnonzero(mine & (labels == name)):
            frames += [int(i)] * (OPENING_HOLD if k == 0 else HOLD)
    return frames


def moved(observation: FaceObservation, rng: np.random.Generator) -> FaceObservation:
    """The frame shifted by a pixel or two with noise, and its landmarks moved with it."""
    dx, dy = (int(v) for v in rng.integers(-SHIFT_PX, SHIFT_PX + 1, 2))
    image = np.roll(observation.image, (dy, dx), axis=(0, 1)).astype(np.float32)
    image = np.clip(image + rng.normal(0.0, NOISE, image.shape), 0, 255).astype(np.uint8)
    landmarks = observation.landmarks + (dx, dy) if observation.landmarks.size else None
    return FaceObservation.from_arrays(image, landmarks, observation.appearance,
                                       observation.fit_failed, observation.fit_reason)


@dataclass
class StreamScores:
    """Frames right per row and opening expression, and the chosen labels' probabilities.

    Attributes
    ----------
    right, total : dict
        ``[row][opening]``: frames labelled correctly, frames.
    confidence, correct : dict
        ``[row]``: probability of each labelled frame's label, and whether it was right.
    changes : dict
        ``[row]``: label changes within held images (flicker), summed over streams.
    """

    right: dict[str, dict[str, int]] = field(default_factory=dict)
    total: dict[str, dict[str, int]] = field(default_factory=dict)
    confidence: dict[str, list[float]] = field(default_factory=dict)
    correct: dict[str, list[bool]] = field(default_factory=dict)
    changes: dict[str, int] = field(default_factory=dict)

    def rate(self, row: str, opening: str | None = None) -> float:
        """Share of frames right, for one opening or all."""
        keys = [opening] if opening else list(self.right[row])
        total = sum(self.total[row][k] for k in keys)
        return sum(self.right[row][k] for k in keys) / max(total, 1)

    def calibration(self, row: str) -> tuple[float, float, list[tuple[str, int, float, float]]]:
        """Mean probability of the chosen labels, their accuracy, and the reliability bins."""
        p, ok = np.array(self.confidence[row]), np.array(self.correct[row], bool)
        if not len(p):
            return float("nan"), float("nan"), []
        return float(p.mean()), float(ok.mean()), reliability(p, ok)


Peer = Callable[[np.ndarray], tuple[str | None, np.ndarray | None]]
"""A classifier of whole frames (a benchmark's peer): its label (a JAFFE class code) and its
probabilities, or (None, None) when it finds no face."""


def _score(out: StreamScores, row: str, opening: str, frames: Sequence[int],
           truth: np.ndarray, answers: Sequence[tuple[str | None, float]]) -> None:
    """Count one stream's answers (label or None, its probability) against the truth."""
    last = None
    for i, (label, p) in zip(frames, answers, strict=True):
        out.total[row][opening] += 1
        if label is None:
            last = None
            continue
        ok = label == truth[i]
        out.right[row][opening] += ok
        out.confidence[row].append(p)
        out.correct[row].append(ok)
        if last is not None and last[0] == i and last[1] != label:
            out.changes[row] += 1
        last = (i, label)


def run_streams(faces: JaffeFaces, appearance_dim: int, rows: Sequence[StreamRow],
                openings: Sequence[str] = SEVEN_CLASSES, seed: int = 0,
                progress: Callable[[str], None] | None = None,
                peers: dict[str, Peer] | None = None) -> StreamScores:
    """Every held-out poser's stream for every opening, through every row (module docstring),
    and through each peer (a row named after it, fed the same frames).

    A frame without a label counts as wrong.
    """
    out = StreamScores()
    names = [row.name for row in rows] + list(peers or {})
    for name in names:
        out.right[name] = dict.fromkeys(openings, 0)
        out.total[name] = dict.fromkeys(openings, 0)
        out.confidence[name], out.correct[name], out.changes[name] = [], [], 0
    posers = faces.posers.astype(str)
    labels = faces.labels.astype(str)
    for poser in np.unique(posers):
        models = {kind: train_deployed(faces, appearance_dim, train=posers != poser,
                                       neutral_reference=kind)
                  for kind in sorted({row.neutral_reference for row in rows})}
        made = [(row, *row.make(models[row.neutral_reference])) for row in rows]
        for opening in openings:
            frames = stream_order(faces, poser, opening)
            rng = np.random.default_rng(seed)
            shown = [moved(faces.observations[i], rng) for i in frames]
            for row, classifier, hold in made:
                recogniser = ExpressionRecogniser(classifier, hold=hold)
                answers: list[tuple[str | None, float]] = []
                for k, obs in enumerate(shown):
                    found = recogniser.recognise(k, obs.image, obs.landmarks if
                                                 obs.landmarks.size else None, obs.appearance,
                                                 obs.fit_failed, obs.fit_reason)
                    if found.label is None or found.scores is None:
                        answers.append((None, 0.0))
                    else:
                        column = found.class_names.index(found.label)
                        answers.append((found.label, float(found.scores[column])))
                _score(out, row.name, opening, frames, labels, answers)
            for name, peer in (peers or {}).items():
                answers = []
                for obs in shown:
                    label, p = peer(obs.image)
                    answers.append((label, 0.0 if p is None else float(p.max())))
                _score(out, name, opening, frames, labels, answers)
        if progress is not None:
            progress(f"poser {poser}: " + ", ".join(f"{out.rate(n):.3f}" for n in names))
    return out


def format_streams(scores: StreamScores, openings: Sequence[str] = SEVEN_CLASSES) -> str:
    """The stream table: per row, the rate per opening expression and overall, the
    flicker, and the calibration (mean probability of the label vs its accuracy)."""
    head = ("| row | " + " | ".join(f"opens {o}" for o in openings)
            + " | all | label changes within a held image | mean p(label) | accuracy of "
            "labelled |")
    lines = [head, "|" + "---|" * (len(openings) + 5)]
    for row in scores.right:
        mean_p, accuracy, _ = scores.calibration(row)
        lines.append(f"| {row} | " + " | ".join(f"{100 * scores.rate(row, o):.1f}"
                                                 for o in openings)
                     + f" | {100 * scores.rate(row):.1f} | {scores.changes[row]} | "
                     f"{100 * mean_p:.1f} | {100 * accuracy:.1f} |")
    return "\n".join(lines)
