"""The options every benchmark shares: ``--model``, ``--data`` and ``--json OUT``."""

from __future__ import annotations

import argparse
import os
from pathlib import Path


def bench_name(module: str) -> str:
    """The tool's name of a benchmark module: ``bench.bench_fit_speed`` is ``fit-speed``."""
    return module.rsplit(".", 1)[-1].removeprefix("bench_").replace("_", "-")


def parser(doc: str | None, module: str, *, model: bool = False) -> argparse.ArgumentParser:
    """A benchmark's parser, named ``python -m bench NAME``, with the shared options;
    ``--model`` where the benchmark loads a fitting model."""
    first = (doc or "").strip().split("\n\n")[0].replace("\n", " ")
    result = argparse.ArgumentParser(prog=f"python -m bench {bench_name(module)}",
                                     description=first)
    shared = result.add_argument_group("shared options (every benchmark)")
    if model:
        shared.add_argument("--model", type=Path, metavar="FILE",
                            help="fitting model (default: the stack's default model, "
                                 "trained and cached on first use)")
    shared.add_argument("--data", type=Path, metavar="DIR",
                        help="data root (default: AAMTRACK_DATA or ../shared/data)")
    shared.add_argument("--json", type=Path, metavar="OUT",
                        help="write the targets table, met or missed, as JSON to OUT")
    return result


def parse(result: argparse.ArgumentParser, argv: list[str] | None) -> argparse.Namespace:
    """Parse ``argv``; ``--data`` becomes ``AAMTRACK_DATA`` for this process and its
    children."""
    args = result.parse_args(argv)
    if args.data is not None:
        if not args.data.is_dir():
            result.error(f"--data {args.data}: no such folder")
        os.environ["AAMTRACK_DATA"] = str(args.data.resolve())
    return args


def model_path(args: argparse.Namespace, **recipe: object) -> Path:
    """``--model``, or the default model's path (trained on first use; ``recipe`` as
    :func:`aamcore.fitting.training.prepare.default_model_path` takes it)."""
    if args.model is not None:
        if not args.model.is_file():
            raise SystemExit(f"--model {args.model}: no such file")
        return args.model
    from aamcore.fitting.training.prepare import default_model_path

    return default_model_path(**recipe)  # type: ignore[arg-type]
