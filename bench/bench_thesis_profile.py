"""Bench: the thesis's pipeline as a profile, beside the default one.

Run: ``OMP_NUM_THREADS=1 python -m bench thesis-profile [--model FILE]
[--svm] [--grid coarse|full]``

1. **Expression, JAFFE protocol** (as ``bench_expression.py``: leave one poser
   out over all 213 faces, a face without a fit or refused by the gate counts
   as wrong, 7 and 5 classes): the thesis's classifiers on the appearance ``c``
   of the thesis profile's fits (the fixed-Jacobian AAM, eq. 7.2), the profile
   deployed (LDA + Mahalanobis) and with ``--svm`` the RBF SVMs; beside them
   the default profile's deployed row (HOG + shape of the local-binary fits).
2. **The profiles on ``videos/single_face.mp4``** through the library
   (``FaceTracker(profile=...)`` with each profile's cached classifier, as
   ``aamtrack run --profile`` runs; smoothing on): frames answered, good fits,
   reliable poses, expressions and their labels, AAM iterations per fit, ms per
   frame (one core).
"""

from __future__ import annotations

import os
import time
from collections import Counter
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.config import data_root
from aamcore.evaluation.expression_lopo import (
    jaffe_faces,
    run_expression_benchmark,
    thesis_specs,
)
from aamcore.evaluation.expression_report import format_benchmark
from aamcore.evaluation.expression_variants import (
    JAFFE_ONLY,
    THESIS_CLASSIFIERS,
    variant_named,
)
from aamcore.expression.svm import SVM_GRIDS
from aamcore.profiles import profile_named
from aamcore.tracker import FaceTracker
from bench import options


def expression_rows(model: Path, svm: bool, grid: str) -> None:
    """Section 1: the thesis rows on the thesis fits, the JAFFE-only row on the default's (the
    deployed classifier's JAFFE row: ``bench_expression.py``)."""
    thesis = profile_named("thesis")
    names = THESIS_CLASSIFIERS if svm else THESIS_CLASSIFIERS[:1]
    variants = [variant_named(f"c, absolute, {name} (thesis)") for name in names]
    specs = thesis_specs(25, *SVM_GRIDS[grid])
    started = time.perf_counter()
    faces = jaffe_faces(model, None, thesis.options.fit.fitting)
    bench = run_expression_benchmark(model, None, variants, (7, 5), specs, faces=faces)
    fitting = thesis.options.fit.fitting
    print(f"thesis profile ({fitting.algorithm}, {fitting.failure_test}): JAFFE "
          f"faces fitted and classified in {time.perf_counter() - started:.0f} s")
    print(format_benchmark(bench))
    started = time.perf_counter()
    default = run_expression_benchmark(model, None, [JAFFE_ONLY], (7, 5), specs)
    print(f"\ndefault profile (local-binary): {time.perf_counter() - started:.0f} s")
    print(format_benchmark(default))


def video_rows(model: Path) -> None:
    """Section 2: each profile over the real video."""
    video = data_root() / "videos" / "single_face.mp4"
    print(f"\n{'profile':<9}{'frames':>7}{'good':>6}{'reliable pose':>14}{'expression':>11}"
          f"{'AAM it/fit':>11}{'ms/frame':>9}  labels")
    for name in ("default", "thesis"):
        tracker = FaceTracker(model=model, profile=name)
        with threadpool_limits(1):
            begun = time.perf_counter()
            results = list(tracker.process_video(video))
            ms = 1000 * (time.perf_counter() - begun) / len(results)
        good = [r for r in results if r.success]
        fits = tracker_iterations(model, name, video)
        labels = Counter(r.expression for r in results if r.expression is not None)
        print(f"{name:<9}{len(results):>7}{len(good):>6}"
              f"{sum(r.pose_reliable for r in results):>14}"
              f"{sum(r.expression is not None for r in results):>11}"
              f"{np.mean(fits) if fits else 0.0:>11.1f}{ms:>9.1f}  {dict(labels)}")


def tracker_iterations(model: Path, profile: str, video: Path) -> list[int]:
    """AAM iterations of each good fit of ``profile``'s fitting over ``video``."""
    from aamcore.fitting.result import AAMFit
    from aamcore.io.video import video_frames

    tracker = FaceTracker(model=model, profile=profile, classifier=False,
                          landmark_smoothing=False, pose_smoothing=False)
    out = []
    for frame in video_frames(video):
        faces, _ = tracker.fit.tracker.track(frame)
        out += [face.fit.iterations for face in faces if isinstance(face.fit, AAMFit)]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__, model=True)
    parser.add_argument("--svm", action="store_true", help="also the thesis's RBF SVM rows")
    parser.add_argument("--grid", choices=tuple(SVM_GRIDS), default="coarse")
    parser.add_argument("--no-expression", action="store_true", help="the video rows only")
    args = options.parse(parser, argv)
    model = options.model_path(args)
    if not args.no_expression:
        expression_rows(model, args.svm, args.grid)
    video_rows(model)
    return 0

