"""Expression on blurred and dim faces: a label only where it would be right as often as on a
sharp face.

Run: ``OMP_NUM_THREADS=1 python -m bench expression-degraded [--faces 150] [--model FILE]``

The held-out people of ``taiwan_expressions`` and ``lfw_expressions`` (``--faces`` of each
set, a fixed draw), each face a fresh stream through ``FaceTracker()`` with its defaults: as
it is; blurred by a Gaussian of 1, 2, 3, 4 and 6 crop pixels (the canonical crop puts the eye
centres 48 pixels apart, so 3 is a sixteenth of the eye distance, whatever the face's size
in the frame); and at half, a quarter, an eighth and a sixteenth of the exposure (grey levels
scaled, sensor noise of 2 levels, rounded); and with a hand of skin like the face's over
part of it (:func:`aamcore.fitting.occluders.draw_occluder`). Each row: the faces fitted,
labelled, labelled right, and the reasons of the rest. Beside them, the quality gate's sharpness
(:func:`aamcore.expression.quality.sharpness`) of every training face as it is, whose 1st
percentile the gate's limit follows (a rule on the training people: the limit was not chosen
on the faces this bench reports).

Targets (issue 46, bad input: "a face too small, blurred, dark or half out of the frame: a
reason, never a confident label"): of the faces blurred by 2 crop pixels or more at most 10 %
labelled; on the faces blurred by 1 pixel and the dim ones, the labels given right within 10
points as often as on sharp faces; at most 2 % of the sharp faces refused as blurred; the
same for a hand over the face ("expression from the visible evidence only").
"""

from __future__ import annotations

import os
import sys
from collections import Counter
from dataclasses import dataclass, field

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2
import numpy as np

from aamcore.expression.crop import aligned_face
from aamcore.expression.quality import BLURRED as BLURRED_REASON
from aamcore.expression.quality import reason_key, sharpness
from aamcore.expression.spec import FeatureConfig
from aamcore.fitting.occluders import draw_occluder
from aamcore.io.expression_sets import load_expression_set
from aamcore.io.sample import read_image
from bench import options
from bench.targets import Target

SETS = ("taiwan_expressions", "lfw_expressions")
LEVELS = (("sharp", 0.0), ("blur", 1.0), ("blur", 2.0), ("blur", 3.0), ("blur", 4.0),
          ("blur", 6.0), ("exposure", 0.5), ("exposure", 0.25), ("exposure", 0.125),
          ("exposure", 0.0625), ("hand", 1.0))
NOISE = 2.0
"""Sensor noise of a dim frame, grey levels (sd)."""
BLURRED = Target("faces blurred by 2 crop pixels or more: labelled", "<=", 10.0, "%")
KEPT_RIGHT = Target("faces blurred by 1 pixel, and dim ones: labels right within 10 points "
                    "of sharp faces'", "==", True)
SHARP_REFUSED = Target("sharp faces refused as blurred", "<=", 2.0, "%")
HAND = Target("a hand over the face: labels right within 10 points of sharp faces', or at "
              "most 10 % labelled", "==", True)
TARGETS = (BLURRED, KEPT_RIGHT, SHARP_REFUSED, HAND)


@dataclass
class Row:
    """What one degradation of the faces gave."""

    kind: str
    level: float
    faces: int = 0
    fitted: int = 0
    labelled: int = 0
    right: int = 0
    reasons: Counter[str] = field(default_factory=Counter)

    @property
    def name(self) -> str:
        if self.kind == "sharp":
            return "sharp"
        if self.kind == "blur":
            return f"blur {self.level:g} px"
        if self.kind == "hand":
            return "hand over it"
        return f"exposure 1/{round(1 / self.level)}"

    def share(self, n: int) -> float:
        return 100.0 * n / self.faces if self.faces else float("nan")

    @property
    def right_share(self) -> float:
        return 100.0 * self.right / self.labelled if self.labelled else float("nan")


def degraded(image: np.ndarray, kind: str, level: float, points: np.ndarray,
             rng: np.random.Generator) -> np.ndarray:
    """``image`` blurred by ``level`` crop pixels, at ``level`` of its exposure, or with a
    hand (of skin like the face's) over part of the face at landmarks ``points`` (68, 2)."""
    eye_px = float(np.hypot(*(points[42:48].mean(axis=0) - points[36:42].mean(axis=0))))
    if kind == "hand":
        return draw_occluder(image, points, rng, "hand")[0]
    if kind == "blur":
        return cv2.GaussianBlur(image, (0, 0), level * eye_px / FeatureConfig().eye_distance)
    if kind == "exposure":
        dim = image.astype(np.float32) * level + rng.normal(0.0, NOISE, image.shape)
        return np.clip(np.round(dim), 0, 255).astype(np.uint8)
    return image


def pick(held: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    index = np.flatnonzero(held)
    return np.sort(rng.choice(index, min(n, len(index)), replace=False))


def held_out_rows(tracker: object, n: int) -> list[Row]:
    """Each degradation's row over ``n`` held-out faces of each set."""
    rows = [Row(kind, level) for kind, level in LEVELS]
    rng = np.random.default_rng(0)
    for name in SETS:
        data = load_expression_set(name)
        for i in pick(data.held_out(), n, rng):
            sample = data.samples[int(i)]
            image = read_image(sample.image_path)
            first = _first(tracker, image)
            if not first.success:
                continue
            for row in rows:
                seen = _first(tracker, degraded(image, row.kind, row.level, first.landmarks,
                                                rng))
                row.faces += 1
                row.fitted += bool(seen.success)
                if seen.expression:
                    row.labelled += 1
                    row.right += seen.expression == sample.label
                else:
                    row.reasons[reason_key(seen.expression_reason)] += 1
    return rows


def _first(tracker: object, image: np.ndarray) -> object:
    tracker.reset()  # type: ignore[attr-defined]
    return tracker.process_faces(image, 0.0)[0]  # type: ignore[attr-defined]


def training_sharpness(tracker: object) -> np.ndarray:
    """The gate's sharpness of every training face of the sets, as they are."""
    config, values = FeatureConfig(), []
    for name in SETS:
        data = load_expression_set(name)
        for i in np.flatnonzero(~data.held_out()):
            image = read_image(data.samples[int(i)].image_path)
            seen = _first(tracker, image)
            if seen.landmarks.size:
                crop, points = aligned_face(image, seen.landmarks, config.crop_size,
                                            config.eye_distance, config.eye_row)
                values.append(sharpness(cv2.equalizeHist(crop), points))
    return np.array(values)


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--faces", type=int, default=150,
                        help="held-out faces of each set (default 150)")
    args = options.parse(parser, argv)
    from aamcore.tracker import FaceTracker

    cv2.setNumThreads(1)
    model = options.model_path(args) if args.model is not None else None
    tracker = FaceTracker(model=model)
    rows = held_out_rows(tracker, args.faces)
    train = training_sharpness(tracker)
    limit = tracker.expression.classifier.pipeline.quality.min_sharpness  # type: ignore
    print(f"{'faces':<16}{'n':>5}{'fitted':>8}{'labelled':>9}{'right':>7}  reasons of the rest")
    for row in rows:
        top = ", ".join(f"{k} {v}" for k, v in row.reasons.most_common(3))
        print(f"{row.name:<16}{row.faces:>5}{row.share(row.fitted):>7.0f}%"
              f"{row.share(row.labelled):>8.0f}%{row.right_share:>6.1f}%  {top}")
    pct = np.percentile(train, [0.5, 1, 5, 50]) if train.size else np.full(4, np.nan)
    print(f"\nevery training face as it is ({train.size}): sharpness 0.5th/1st/5th/50th "
          f"percentile {pct[0]:.1f} / {pct[1]:.1f} / {pct[2]:.1f} / {pct[3]:.1f}; the gate's "
          f"limit {limit:g} (its rule: the 1st percentile), {int((train < limit).sum())} "
          f"below it ({100 * np.mean(train < limit):.1f} %)")
    sharp = rows[0]
    blurred = [row for row in rows if row.kind == "blur" and row.level >= 2.0]
    faces, labelled = sum(r.faces for r in blurred), sum(r.labelled for r in blurred)
    BLURRED.check(100.0 * labelled / max(faces, 1), f"{labelled} of {faces}")
    hand = next(row for row in rows if row.kind == "hand")
    HAND.check(hand.share(hand.labelled) <= 10.0 or hand.right_share >= sharp.right_share - 10,
               f"{hand.share(hand.labelled):.0f}% labelled, {hand.right_share:.1f}% right "
               f"(sharp {sharp.right_share:.1f}%)")
    kept = [row for row in rows[1:] if row not in blurred and row is not hand and row.labelled]
    worse = [f"{row.name} {row.right_share:.1f}%" for row in kept
             if not row.right_share >= sharp.right_share - 10.0]
    KEPT_RIGHT.check(not worse, ("below: " + ", ".join(worse)) if worse else
                     f"sharp {sharp.right_share:.1f}%, the others "
                     + ", ".join(f"{row.right_share:.1f}" for row in kept))
    SHARP_REFUSED.check(sharp.share(sharp.reasons[BLURRED_REASON]),
                        f"{sharp.reasons[BLURRED_REASON]} of {sharp.faces}")
    tracker.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
