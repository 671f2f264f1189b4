"""``aamtrack eval expression``: JAFFE's leave-one-poser-out protocol for JAFFE-only pipelines.

Prints the table of leave-one-poser-out rates over all JAFFE faces (or, with
``--json``, the full results) of the pipelines trained on the other JAFFE posers
alone: the deployed pipeline before the three expression sets, comparison rows and the
thesis's classifiers. The deployed classifier is measured on the held-out people of the
three sets by ``python -m bench expression``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from aamcore import defaults
from services.cli.groups import eval_group


def _counts(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not a comma-separated list of integers: {text}") from exc
    if not values or not set(values) <= {5, 7}:
        raise argparse.ArgumentTypeError(f"class counts must be 7 and/or 5: {text}")
    return values


def add_benchmark_options(parser: argparse.ArgumentParser) -> None:
    """The options the command and ``python -m bench expression`` share."""
    parser.add_argument("--only", action="append", default=[], metavar="TEXT",
                        help="only the rows whose name contains TEXT (repeatable), e.g. "
                        "--only 'JAFFE only'")
    parser.add_argument("--classes", type=_counts, default=[7, 5],
                        help="class sets: 7, 5 or 7,5 (default)")
    parser.add_argument("--trials", type=int, default=25,
                        help="k-means trials choosing the Fisher directions (thesis rows)")
    parser.add_argument("--grid", choices=defaults.SVM_GRID_NAMES, default="full",
                        help="SVM C and gamma grid of the thesis rows (coarse: quick runs)")
    parser.add_argument("--data", metavar="DIR", help="JAFFE folder (default: <data root>/jaffe)")
    parser.add_argument("--fit-model", type=Path, metavar="FILE",
                        help="fitting model that fits the faces (default: the stack's default "
                        "model, trained on first use)")
    parser.add_argument("--out", metavar="DIR", help="write results.json, confusion tables "
                        "and PNGs here")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``eval expression``."""
    parser = eval_group(subparsers).add_parser(
        "expression",
        help="leave-one-poser-out expression recognition on JAFFE (JAFFE-only pipelines)",
        description="Leave-one-poser-out expression recognition over all JAFFE faces, fitted "
        "as the stack fits them, of pipelines trained on the other JAFFE posers alone: the "
        "pipeline deployed before the three expression sets (HOG patches + canonical shape "
        "relative to the face's reference, shrinkage LDA), comparison rows and the thesis's "
        "classifiers (LDA+Mahalanobis, RBF SVMs) on the fitter's appearance vector, for 7 and "
        "5 classes. The deployed classifier: python -m bench expression.",
    )
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    add_benchmark_options(parser)
    parser.set_defaults(func=run)


def benchmark(args: argparse.Namespace):  # -> ExpressionBenchmark (imported late)
    """Run the benchmark the options ask for (progress lines on standard error)."""
    from aamcore.evaluation.expression_lopo import run_expression_benchmark, thesis_specs
    from aamcore.evaluation.expression_variants import select
    from aamcore.expression.svm import SVM_GRIDS
    from aamcore.fitting.training.prepare import default_model_path

    if args.trials < 1:
        raise ValueError(f"--trials must be at least 1, got {args.trials}")
    variants = select(args.only)
    model = args.fit_model or default_model_path()
    bench = run_expression_benchmark(
        model, args.data, variants, args.classes, thesis_specs(args.trials, *SVM_GRIDS[args.grid]),
        progress=lambda line: print(line, file=sys.stderr, flush=True),
    )
    if args.out:
        from aamcore.evaluation.expression_report import write_outputs

        write_outputs(bench, args.out)
    return bench


def run(args: argparse.Namespace) -> int:
    """Run the benchmark and print its table; 0."""
    from aamcore.evaluation.expression_report import format_benchmark

    bench = benchmark(args)
    print(json.dumps(bench.to_dict(), indent=1) if args.json else format_benchmark(bench))
    return 0
