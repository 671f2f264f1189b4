"""``aamtrack train``: build a model from an annotated dataset."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aamcore.io import FaceSample
    from aamcore.model.training import TrainConfig




def add_train_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by every command that trains a model."""
    parser.add_argument("--shape-variance", type=float, default=0.95)
    parser.add_argument("--texture-variance", type=float, default=0.95)
    parser.add_argument("--combined-variance", type=float, default=0.95)
    parser.add_argument(
        "--pixels",
        type=int,
        default=10_000,
        help="approximate pixels inside the reference frame (default 10000)",
    )
    parser.add_argument("--grey", action="store_true", help="grey texture instead of colour")
    parser.add_argument(
        "--equalise", action="store_true", help="histogram-equalise the face region per channel"
    )


def config_from(args: argparse.Namespace) -> TrainConfig:
    """The :class:`TrainConfig` the options describe."""
    from aamcore.model.training import TrainConfig

    return TrainConfig(
        shape_variance=args.shape_variance,
        texture_variance=args.texture_variance,
        combined_variance=args.combined_variance,
        n_pixels=args.pixels,
        colour=not args.grey,
        equalise=args.equalise,
    )


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("train", help="train an AAM from annotated faces")
    p.add_argument(
        "--data",
        required=True,
        help="imm_frontal, lfpw, or a folder of .asf/.pts files with images",
    )
    p.add_argument("--out", type=Path, help="model file (default: in the cache folder)")
    p.add_argument("--limit", type=int, help="use at most this many images")
    p.add_argument(
        "--hold-out-subjects",
        default="",
        help="comma-separated subject ids left out of training (IMM: 10,11,12)",
    )
    p.add_argument(
        "--train-fraction",
        type=float,
        default=1.0,
        help="train on this first fraction of the images in name order "
        "(LFPW: 0.8; the rest is the test split)",
    )
    p.add_argument(
        "--fit",
        action="store_true",
        help="also train what fitting needs (box mapping, update matrices, descent cascade)",
    )
    add_train_options(p)
    p.set_defaults(func=run)


def select_training(
    samples: list[FaceSample], hold_out_subjects: str = "", fraction: float = 1.0
) -> list[FaceSample]:
    """The training samples: without the held-out subjects, the first ``fraction`` by name."""
    held = {s.strip() for s in hold_out_subjects.split(",") if s.strip()}
    chosen = [s for s in samples if s.subject is None or s.subject not in held]
    if not 0 < fraction <= 1:
        raise ValueError(f"--train-fraction {fraction} is not in (0, 1]")
    return chosen[: max(int(round(fraction * len(chosen))), 1)]


def run(args: argparse.Namespace) -> int:
    from aamcore.config import cache_dir, resolve_dataset
    from aamcore.fitting.training.prepare import train_fitting_model
    from aamcore.io import load_annotated_folder
    from aamcore.model.cache import cache_key
    from aamcore.model.file import read_header, save_model
    from aamcore.model.training import train_aam
    from aamcore.progress import bar
    from services.cli.model_cmd import print_summary

    config = config_from(args)
    folder = resolve_dataset(args.data)
    data = load_annotated_folder(folder, limit=args.limit)
    for error in data.errors:
        print(f"skipped: {error}", file=sys.stderr)
    print(
        f"{len(data.samples)} images of {folder} ({data.scheme.name}), {len(data.errors)} skipped",
        file=sys.stderr,
    )
    samples = select_training(data.samples, args.hold_out_subjects, args.train_fraction)
    extra = {"hold_out": args.hold_out_subjects, "fraction": args.train_fraction, "fit": args.fit}
    out = args.out or cache_dir() / f"{folder.name}-{cache_key(str(folder), config, extra)}.npz"
    aam = train_aam(samples, data.scheme, config, progress=bar("appearance model"),
                    source=str(folder))
    aam.summary["skipped"] = data.errors + aam.summary["skipped"]
    if args.fit:
        print(
            "training the fitters (box mapping, update matrices, descent cascade)", file=sys.stderr
        )
        path = train_fitting_model(aam, samples, progress=bar("update matrices")).save(out)
    else:
        path = save_model(aam, out)
    print_summary(read_header(path), path)
    return 0
