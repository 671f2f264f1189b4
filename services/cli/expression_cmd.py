"""``aamtrack eval expression``: the JAFFE expression recognition benchmark.

Prints the table of overall leave-one-poser-out rates (or, with ``--json``,
the full results), and exits 0 when every target is met, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from aamcore import defaults
from services.cli.groups import eval_group

FEATURE_KINDS = ("aam", "pixels")
"""Feature extractors available to the command (the AAM one comes with AAM fitting)."""


def _fractions(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not a comma-separated list of numbers: {text}") from exc
    values = [v / 100.0 if v > 1.0 else v for v in values]
    if not values or not all(0.0 < v < 1.0 for v in values):
        raise argparse.ArgumentTypeError(f"variances must be in (0, 1) or (0, 100) %: {text}")
    return values


def _counts(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not a comma-separated list of integers: {text}") from exc
    if not values or not set(values) <= {5, 7}:
        raise argparse.ArgumentTypeError(f"class counts must be 7 and/or 5: {text}")
    return values


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``eval expression``."""
    parser = eval_group(subparsers).add_parser(
        "expression",
        help="leave-one-poser-out expression recognition on JAFFE",
        description="Leave-one-poser-out expression recognition on JAFFE with LDA+Mahalanobis "
        "and RBF SVMs (one-against-all, one-against-one, DAG), for 7 and 5 classes.",
    )
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument(
        "--features",
        choices=FEATURE_KINDS,
        default="aam",
        help="feature extractor: aam (appearance vectors of a per-fold AAM on faces fitted by "
        "the LFPW fitter, default) or pixels (face-crop pixel PCA baseline)",
    )
    parser.add_argument("--out", metavar="DIR", help="write confusion tables, PNGs and JSON here")
    parser.add_argument(
        "--variances",
        type=_fractions,
        default=list(defaults.EXPRESSION_VARIANCES),
        help="kept PCA variance fractions, comma-separated (default: table 9.2's)",
    )
    parser.add_argument(
        "--classes", type=_counts, default=[7, 5], help="class sets: 7, 5 or 7,5 (default)"
    )
    parser.add_argument(
        "--trials", type=int, default=25, help="k-means trials choosing the Fisher directions"
    )
    parser.add_argument(
        "--grid",
        choices=defaults.SVM_GRID_NAMES,
        default="full",
        help="SVM C and gamma grid searched in each fold (coarse: quick runs)",
    )
    parser.add_argument("--data", metavar="DIR", help="JAFFE folder (default: <data root>/jaffe)")
    parser.add_argument(
        "--fit-model",
        type=Path,
        help="68-point model that fits the faces for --features aam (default: the stack's "
        "LFPW model, trained on first use)",
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark; return 0 when every target is met, else 1."""
    from aamcore.expression.benchmark import (
        format_benchmark,
        load_aam_data,
        load_pixel_data,
        run_expression_benchmark,
    )
    from aamcore.expression.svm import SVM_GRIDS
    from aamcore.fitting.fitter import Fitter
    from aamcore.fitting.model import FittingModel

    if args.trials < 1:
        raise ValueError(f"--trials must be at least 1, got {args.trials}")
    C_grid, gamma_grid = SVM_GRIDS[args.grid]
    if args.features == "aam":
        fitter = (Fitter(FittingModel.load(args.fit_model), appearance=True) if args.fit_model
                  else None)
        data = load_aam_data(args.data, fitter)
    else:
        data = load_pixel_data(args.data)
    bench = run_expression_benchmark(
        data=data,
        variances=args.variances,
        class_counts=args.classes,
        n_trials=args.trials,
        out_dir=args.out,
        progress=lambda line: print(line, file=sys.stderr, flush=True),
        C_grid=C_grid,
        gamma_grid=gamma_grid,
    )
    if args.json:
        print(json.dumps(bench.to_dict(), indent=1))
    else:
        print(format_benchmark(bench))
    return 0 if bench.passed() else 1
