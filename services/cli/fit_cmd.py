"""``aamtrack fit`` and ``aamtrack eval fit|landmarks``: fitting images and measuring it."""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict
from pathlib import Path

from aamcore import defaults
from aamcore.fitting.algorithm import ALGORITHMS
from services.cli.commands import add_command
from services.cli.groups import eval_group


def register(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "fit")
    p.add_argument("images", nargs="+", type=Path, help="images to fit (one face each)")
    p.add_argument("--model", type=Path, required=True,
                   help="fitting model file (aamtrack train --fit --out FILE)")
    _algorithm_option(p)
    p.add_argument("--draw", type=Path, help="folder for the images with the fitted mesh")
    p.add_argument("--out", type=Path, help="JSON file (default: standard output)")
    p.set_defaults(func=run_fit)

    ev = eval_group(sub)
    e = ev.add_parser("fit", help="Monte Carlo start displacements (thesis section 7.3)")
    e.add_argument("--model", type=Path, required=True,
                   help="fitting model file (aamtrack train --fit --out FILE)")
    e.add_argument("--data", required=True, help="annotated folder or dataset name")
    _algorithm_option(e)
    e.add_argument("--starts", default=",".join(defaults.FIT_STARTS), help="cog, haar or both")
    e.add_argument(
        "--offsets",
        default=",".join(str(o) for o in defaults.THESIS_OFFSETS),
        help="start displacements in pixels (default: the thesis's -50..50)",
    )
    e.add_argument("--limit", type=int, help="at most this many held-out images")
    e.add_argument("--ced", type=Path, help="PNG of the cumulative NME distribution")
    e.add_argument("--json", action="store_true", help="print the results as JSON")
    e.set_defaults(func=run_eval_fit)

    lm = ev.add_parser("landmarks", help="NME of fits from the Haar start on an annotated folder")
    lm.add_argument("--model", type=Path, required=True,
                    help="fitting model file (aamtrack train --fit --out FILE)")
    lm.add_argument("--data", required=True, help="annotated folder or dataset name")
    _algorithm_option(lm)
    lm.add_argument("--limit", type=int, help="at most this many held-out images")
    lm.add_argument("--ced", type=Path, help="PNG of the cumulative NME distribution")
    lm.add_argument("--json", action="store_true", help="print the results as JSON")
    lm.set_defaults(func=run_eval_landmarks)


def _algorithm_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--algorithm",
        choices=list(ALGORITHMS),
        default=defaults.ALGORITHM,
        help=f"fitting algorithm (default {defaults.ALGORITHM})",
    )


def run_fit(args: argparse.Namespace) -> int:
    import cv2
    import numpy as np

    from aamcore.detection.haar import HaarFaceDetector
    from aamcore.fitting.fitter import Fitter
    from aamcore.fitting.model import FittingModel
    from aamcore.fitting.result import AAMFit
    from aamcore.io import read_image
    from aamcore.model.visualise import draw_shape

    fitter = Fitter(FittingModel.load(args.model), args.algorithm)
    aam = fitter.aam
    detector = HaarFaceDetector()
    results = []
    for path in args.images:
        image = read_image(path)
        boxes = detector.detect(image)
        if len(boxes) == 0:
            results.append({"image": str(path), "face": False})
            continue
        fit = fitter.fit_box(image, boxes[0])
        results.append(
            {
                "image": str(path),
                "face": True,
                "box": boxes[0].tolist(),
                "landmarks": np.round(fit.points, 3).tolist(),
                "failed": fit.failed,
                "reason": fit.reason,
                "iterations": getattr(fit, "iterations", 0),
                "texture_error": (fit.error if isinstance(fit, AAMFit)
                                  and math.isfinite(fit.error) else None),
                "confidence": fit.confidence,
                "scheme": aam.scheme.name,
            }
        )
        if args.draw:
            args.draw.mkdir(parents=True, exist_ok=True)
            colour = (0, 0, 255) if fit.failed else (0, 255, 0)
            canvas = draw_shape(image.copy(), fit.points, aam.scheme, colour)
            cv2.imwrite(str(args.draw / f"{path.stem}_fit.png"), canvas)
    text = json.dumps(results, indent=1)
    if args.out:
        args.out.write_text(text)
    else:
        print(text)
    return 0


def _test_samples(args: argparse.Namespace, aam) -> list:
    from aamcore.config import resolve_dataset
    from aamcore.evaluation.fits import held_out
    from aamcore.io import load_annotated_folder

    data = load_annotated_folder(resolve_dataset(args.data))
    if data.scheme.n_points != aam.scheme.n_points:
        raise ValueError(
            f"{args.data} has {data.scheme.n_points}-point annotations, the model "
            f"{aam.scheme.n_points}"
        )
    samples = held_out(aam, data.samples)
    if not samples:
        raise ValueError(f"every image of {args.data} was used to train the model: nothing to test")
    return samples[: args.limit] if args.limit else samples


def run_eval_fit(args: argparse.Namespace) -> int:
    from aamcore.evaluation.fits import failure_rates, format_failure_table, monte_carlo, summary
    from aamcore.evaluation.plots import save_ced_png
    from aamcore.fitting.fitter import Fitter
    from aamcore.fitting.model import FittingModel

    fitter = Fitter(FittingModel.load(args.model), args.algorithm)
    aam = fitter.aam
    samples = _test_samples(args, aam)
    offsets = [float(o) for o in args.offsets.split(",") if o.strip()]
    starts = [s.strip() for s in args.starts.split(",") if s.strip()]
    print(
        f"{fitter.name}: {len(samples)} held-out images x {len(offsets)} offsets x 2 axes x "
        f"{len(starts)} starts",
        file=sys.stderr,
    )
    records = monte_carlo(fitter, samples, offsets, starts)
    rates = failure_rates(records)
    result = {
        "algorithm": fitter.name,
        "images": len(samples),
        "summary": summary(records),
        "failure_rates": {
            k: {a: {str(o): c for o, c in v.items()} for a, v in d.items()}
            for k, d in rates.items()
        },
        "by_start": {k: summary([r for r in records if r.start == k]) for k in rates},
    }
    if args.ced:
        save_ced_png({k: [r.nme for r in records if r.start == k] for k in rates}, args.ced)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        for kind in rates:
            print(f"\nfailure rate, {kind} start (eq. 7.2: a parameter beyond 3 sd)")
            print(format_failure_table(rates[kind], "eq72"))
            print(f"\nfailure rate, {kind} start (NME > 0.10)")
            print(format_failure_table(rates[kind], "nme"))
    return 0


def run_eval_landmarks(args: argparse.Namespace) -> int:
    from aamcore.evaluation.fits import landmark_errors, summary
    from aamcore.evaluation.plots import save_ced_png
    from aamcore.fitting.fitter import Fitter
    from aamcore.fitting.model import FittingModel

    fitter = Fitter(FittingModel.load(args.model), args.algorithm)
    aam = fitter.aam
    samples = _test_samples(args, aam)
    records = landmark_errors(fitter, samples)
    stats = summary(records)
    result = {
        "algorithm": fitter.name,
        "images": len(samples),
        **stats,
        "fits": [asdict(r) for r in records],
    }
    if args.ced:
        save_ced_png({fitter.name: [r.nme for r in records]}, args.ced)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(
            f"{fitter.name} on {len(samples)} images ({stats['landmark_box_starts']} from the "
            f"landmark box): NME mean {stats['mean']:.4f}, median {stats['median']:.4f}, "
            f"> 0.08 {stats['failure_008']:.1%}, > 0.10 {stats['failure_010']:.1%}, "
            f"{1000 * stats['mean_seconds']:.1f} ms per fit"
        )
    return 0
