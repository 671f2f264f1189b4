"""Stream-order sequences of held-out Taiwanese performers, through the library's tracker
(``bench_expression.py --streams``).

Neither expression set has sequences; a user's stream may open calm or on a laugh. Each
held-out performer's images become streams, one per opening expression: the images of
that class first (each held :data:`OPENING_HOLD` frames), then the other classes' in
:data:`~aamcore.expression.labels.SEVEN_CLASSES` order from there (each held :data:`HOLD`
frames), every frame moved by a pixel or two and given sensor noise. The stream opening on
``NE`` is calm, then expressive. Each stream runs through
:class:`~aamcore.tracker.FaceTracker` as the stack runs (Haar, tracking, smoothed
landmarks, the expression recogniser with the stack's label hold) with the deployed
classifier; the other rows read the same tracked fits, and a peer the same frames. A frame
without a label counts as wrong.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from aamcore.evaluation.expression_data import BenchFaces
from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.network import NetworkModel
from aamcore.expression.recogniser import STACK_HOLD, ExpressionRecogniser
from aamcore.tracker import FaceTracker

OPENING_HOLD = 30
"""Frames each image of the opening expression is held (about three images: three
seconds)."""
HOLD = 8
"""Frames each later image is held."""
SHIFT_PX = 2
"""Largest shift of a frame, pixels."""
NOISE = 3.0
"""Standard deviation of the grey-level noise added to every frame."""
DEPLOYED_ROW = f"deployed: FaceTracker, smoothed landmarks, label hold {STACK_HOLD}"
Peer = Callable[[np.ndarray], tuple[str | None, np.ndarray | None]]


def stream_order(labels: np.ndarray, members: np.ndarray, opening: str) -> list[int]:
    """The face of each frame of the stream of faces ``members`` opening on ``opening``."""
    order = list(SEVEN_CLASSES)
    order = order[order.index(opening):] + order[:order.index(opening)]
    frames: list[int] = []
    for k, name in enumerate(order):
        for i in members[labels[members] == name]:
            frames += [int(i)] * (OPENING_HOLD if k == 0 else HOLD)
    return frames


def moved(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The frame shifted by up to :data:`SHIFT_PX` pixels, with sensor noise."""
    dx, dy = (int(v) for v in rng.integers(-SHIFT_PX, SHIFT_PX + 1, 2))
    shifted = np.roll(image, (dy, dx), axis=(0, 1)).astype(np.float32)
    return np.clip(shifted + rng.normal(0.0, NOISE, shifted.shape), 0, 255).astype(np.uint8)


def person_independent(classifier: ExpressionClassifier) -> ExpressionClassifier:
    """The classifier's person-independent model alone (no reference at all)."""
    if classifier.absolute is None:
        return classifier
    kind = "network" if isinstance(classifier.absolute, NetworkModel) else "linear"
    return replace(classifier, kind=kind, model=classifier.absolute, absolute=None,
                   temperature=classifier.absolute_temperature,
                   pipeline=replace(classifier.pipeline, relative=False))


@dataclass
class StreamScores:
    """Frames right and frames, per row and opening expression."""

    right: dict[str, dict[str, int]] = field(default_factory=dict)
    total: dict[str, dict[str, int]] = field(default_factory=dict)

    def add(self, row: str, opening: str, ok: bool) -> None:
        self.right.setdefault(row, {}).setdefault(opening, 0)
        self.total.setdefault(row, {}).setdefault(opening, 0)
        self.right[row][opening] += int(ok)
        self.total[row][opening] += 1

    def rate(self, row: str, opening: str | None = None) -> float:
        """Share of frames right, for one opening or all."""
        keys = [opening] if opening else list(self.right[row])
        return sum(self.right[row][k] for k in keys) / max(
            sum(self.total[row][k] for k in keys), 1)


def run_streams(bench: BenchFaces, model: str | Path, classifier: str | Path,
                performers: Sequence[str] | None = None,
                openings: Sequence[str] = SEVEN_CLASSES, peer: tuple[str, Peer] | None = None,
                seed: int = 0, say: Callable[[str], None] | None = None) -> StreamScores:
    """Every held-out performer's stream for every opening (module docstring)."""
    loaded = ExpressionClassifier.load(classifier)
    alone = person_independent(loaded)
    taiwan = (bench.sets == "taiwan_expressions") & bench.held
    names = np.unique(bench.persons[taiwan]) if performers is None else [
        f"taiwan_expressions/{p}" for p in performers]
    out = StreamScores()
    labels = bench.labels.astype(str)
    for person in names:
        members = np.flatnonzero(taiwan & (bench.persons == person))
        images = {int(i): bench.faces.image(int(i)) for i in members}
        for opening in openings:
            frames = stream_order(labels, members, opening)
            rng = np.random.default_rng(seed)
            tracker = FaceTracker(model=model, classifier=classifier,
                                  expression_hold=STACK_HOLD)
            other = ExpressionRecogniser(alone, hold=STACK_HOLD)
            for k, i in enumerate(frames):
                frame = moved(images[i], rng)
                result = tracker.process(frame)
                out.add(DEPLOYED_ROW, opening, result.expression == labels[i])
                found = other.recognise(k, frame, result.landmarks if len(result.landmarks)
                                        else None, None, not result.success, result.reason,
                                        occluded=result.occluded)
                out.add("person-independent alone (same fits)", opening,
                        found.label == labels[i])
                if peer is not None:
                    out.add(peer[0], opening, peer[1](frame)[0] == labels[i])
        if say is not None:
            say(f"{person}: " + ", ".join(f"{row} {100 * out.rate(row):.1f}%"
                                          for row in out.right))
    return out


def format_streams(scores: StreamScores, openings: Sequence[str] = SEVEN_CLASSES) -> str:
    """Per row, the share of frames right per opening expression and overall."""
    head = "| row | " + " | ".join(f"opens {o}" for o in openings) + " | all |"
    lines = [head, "|---" * (len(openings) + 2) + "|"]
    for row in scores.right:
        lines.append(f"| {row} | " + " | ".join(f"{100 * scores.rate(row, o):.1f}"
                                                 for o in openings)
                     + f" | {100 * scores.rate(row):.1f} |")
    return "\n".join(lines)
