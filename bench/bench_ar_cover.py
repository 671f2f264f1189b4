"""AR-cover bench: the glasses hidden where a hand covers the face, kept where it does not.

Each held-out photo of LFPW, HELEN and AFW (faces the fitting model never saw;
``bench/tracking_clips.py``'s split) gets a hand of real skin tones
(:func:`aamcore.fitting.occluders.draw_occluder`, kind ``hand``) over its eyes and brows,
a few seeds each. The photo with the hand is a fresh stream of :data:`FRAMES` frames
through :class:`aamcore.tracker.FaceTracker` (its fit and pose stages, the default
profile); the overlay stage then draws the glasses at the last frame's pose twice: as
deployed (``hide_covered``: the frame shows through around the landmarks the fit flags
occluded, :mod:`aamcore.ar.cover`) and with ``hide_covered`` off.

Scored on the faces with a reliable pose whose glasses would cover at least
:data:`MIN_PIXELS` pixels of the hand: of the pixels where the glasses and the hand
overlap, the share the glasses are drawn over (hidden: 0 %); of the glasses' pixels on the
visible face (a few pixels away from the hand), the share still drawn. ``--out DIR`` writes
each scored face's two overlays side by side as PNG (never into the repository: they are
faces of the data folder).

Targets: the glasses drawn over <= 25 % of the hand they would cover; >= 90 % of them kept
on the visible face.

Run: ``OMP_NUM_THREADS=1 python -m bench ar-cover [--model FILE] [--per-set 20]
[--seeds 3] [--out DIR]``
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2
import numpy as np

from aamcore.fitting.model import FittingModel
from aamcore.fitting.occluders import draw_occluder
from aamcore.operators.faces import FrameRef
from aamcore.operators.options import OverlayOptions
from aamcore.operators.overlay import OverlayOperator
from aamcore.tracker import FaceTracker
from bench import options
from bench.targets import Target
from bench.tracking_clips import SETS, held_out_photos

OVER_HAND = Target("glasses drawn over the hand they would cover", "<=", 25.0, "%")
KEPT = Target("glasses kept on the visible face", ">=", 90.0, "%")
TARGETS = (OVER_HAND, KEPT)
FRAMES = 5
"""Frames of each fresh stream: the fit settles in a few."""
MIN_PIXELS = 50
"""Pixels of the hand the glasses must cover for a face to be scored."""
UPPER = slice(17, 48)
"""Brows, nose and eyes: where the hand is put (the glasses' part of the face)."""


def overlays(tracker: FaceTracker, image: np.ndarray, on: OverlayOperator,
             off: OverlayOperator) -> tuple[np.ndarray, np.ndarray, int] | None:
    """The overlays of ``image`` with and without the cover, and the landmarks flagged,
    None without a reliable pose."""
    tracker.reset()
    height, width = image.shape[:2]
    for k in range(FRAMES):
        ref = FrameRef(k, k / 30.0, width, height)
        faces = tracker.fit(image, ref)
        poses = tracker.pose(ref, faces)
    if not poses or not poses[0].reliable:
        return None
    flagged = 0 if poses[0].covered is None else len(poses[0].covered)
    return on(image, poses[:1]), off(image, poses[:1]), flagged


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--per-set", type=int, default=20, help="held-out photos per set")
    parser.add_argument("--seeds", type=int, default=3, help="hands per photo")
    parser.add_argument("--out", type=Path, help="folder for the side-by-side PNGs")
    args = options.parse(parser, argv)
    model = FittingModel.load(options.model_path(args))
    if model.occlusion is None:
        sys.exit("this model has no occlusion part: retrain it")
    tracker = FaceTracker(model=model, classifier=False, landmark_smoothing=False,
                          pose_smoothing=False)
    on = OverlayOperator(OverlayOptions(hide_covered=True))
    off = OverlayOperator(OverlayOptions(hide_covered=False), ctx=None)
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
    over = [0, 0]  # the hand's pixels under the glasses: drawn over, all
    kept = [0, 0]  # the glasses' pixels on the visible face: drawn, all
    scored = unreliable = small = 0
    print(f"{'face':<28}{'flagged':>8}{'hand px':>9}{'over hand':>10}{'kept':>7}")
    for set_name in SETS:
        for sample in held_out_photos(model, set_name, args.per_set):
            clean = sample.load_image()
            if clean.ndim == 2:
                clean = cv2.cvtColor(clean, cv2.COLOR_GRAY2BGR)
            for seed in range(args.seeds):
                rng = np.random.default_rng(1000 * seed + 17)
                image, hand = draw_occluder(clean, sample.points[UPPER], rng, "hand")
                found = overlays(tracker, image, on, off)
                if found is None:
                    unreliable += 1
                    continue
                with_cover, without, flagged = found
                glasses = np.any(without != image, axis=2)
                under = glasses & hand
                if under.sum() < MIN_PIXELS:
                    small += 1
                    continue
                near = cv2.dilate(hand.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
                visible = glasses & ~near
                drawn_on = np.any(with_cover != image, axis=2)
                over[0] += int((drawn_on & under).sum())
                over[1] += int(under.sum())
                kept[0] += int((drawn_on & visible).sum())
                kept[1] += int(visible.sum())
                scored += 1
                name = f"{set_name} {Path(sample.image_path).stem} #{seed}"
                print(f"{name:<28}{flagged:>8}{int(under.sum()):>9}"
                      f"{(drawn_on & under).sum() / under.sum():>10.0%}"
                      f"{(drawn_on & visible).sum() / max(visible.sum(), 1):>7.0%}")
                if args.out:
                    png = args.out / f"{set_name}-{Path(sample.image_path).stem}-{seed}.png"
                    cv2.imwrite(str(png), np.hstack([without, with_cover]))
    on.close()
    off.close()
    print(f"\n{scored} faces scored; {small} with the hand clear of the glasses, {unreliable} "
          "without a reliable pose (not scored)")
    if not scored:
        print("no face scored")
        return 1
    passed = OVER_HAND.check(100 * over[0] / over[1], f"{over[1]} pixels (100 % with "
                             "hide_covered off)")
    passed &= KEPT.check(100 * kept[0] / max(kept[1], 1), f"{kept[1]} pixels")
    return 0 if passed else 1
