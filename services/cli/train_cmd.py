"""``aamtrack train``: build a model from an annotated dataset."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from services.cli.commands import add_command

if TYPE_CHECKING:
    from aamcore.io import FaceSample
    from aamcore.model.training import TrainConfig




def add_train_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by every command that trains a model."""
    parser.add_argument("--shape-variance", type=float, default=0.95,
                        help="share of the shape variance the shape modes keep (default 0.95)")
    parser.add_argument("--texture-variance", type=float, default=0.95,
                        help="share of the texture variance the texture modes keep (default 0.95)")
    parser.add_argument("--combined-variance", type=float, default=0.95,
                        help="share of the combined appearance variance its modes keep "
                             "(default 0.95)")
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
    from aamcore import defaults

    p = add_command(sub, "train")
    p.add_argument(
        "--data",
        required=True,
        help="comma-separated dataset names or folders of .asf/.pts files with images "
        "(imm_frontal, lfpw, helen, afw; lfpw, helen and afw give their training split "
        f"only); the default model's is {defaults.MODEL_DATASET}",
    )
    p.add_argument("--out", type=Path, help="model file (default: in the cache folder)")
    p.add_argument("--limit", type=int, help="use at most this many images (shared among "
                   "the folders)")
    p.add_argument(
        "--hold-out-subjects",
        default="",
        help="comma-separated subject ids left out of training (IMM: 10,11,12)",
    )
    p.add_argument(
        "--train-fraction",
        type=float,
        default=1.0,
        help="train on this first fraction of the images in name order",
    )
    p.add_argument(
        "--fit",
        action="store_true",
        help="also train what fitting needs (box mapping, update matrices, descent cascade, "
        "the local-binary cascade of the default method)",
    )
    p.add_argument("--update", choices=("jacobian", "regression"), default="jacobian",
                   help="with --fit: how the fixed-Jacobian AAM's update matrices are learned: "
                   "jacobian (thesis Algorithm 6, the default) or regression (Algorithm 5)")
    p.add_argument("--mirror", action=argparse.BooleanOptionalAction, default=True,
                   help="with --fit: also train the local-binary cascade on every face "
                   "flipped left-right (iBUG-68 markup; default on)")
    p.add_argument("--aam-images", type=int, default=defaults.MODEL_AAM_IMAGES, metavar="N",
                   help="train the AAM (and the descent cascade) on at most N faces spread "
                   f"over the training faces (default {defaults.MODEL_AAM_IMAGES}; 0: all)")
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
    from aamcore.config import cache_dir
    from aamcore.fitting.training.data import training_set
    from aamcore.fitting.training.prepare import MIRRORS, subset, train_fitting_model
    from aamcore.model.cache import cache_key
    from aamcore.model.file import read_header, save_model
    from aamcore.model.training import train_aam
    from aamcore.progress import bar
    from services.cli.model_cmd import print_summary

    config = config_from(args)
    data = training_set(args.data, args.limit)
    for error in data.errors:
        print(f"skipped: {error}", file=sys.stderr)
    if args.fit and args.mirror and data.scheme.name not in MIRRORS:
        raise SystemExit(f"aamtrack train: --mirror needs a markup with a left-right "
                         f"permutation ({', '.join(MIRRORS)}), {args.data} has "
                         f"{data.scheme.name}: give --no-mirror")
    samples = select_training(data.samples, args.hold_out_subjects, args.train_fraction)
    parts = ", ".join(f"{f}{' (training split)' if s else ''}"
                      for f, s in zip(data.folders, data.split, strict=True))
    print(f"{len(samples)} faces of {parts} ({data.scheme.name}), {len(data.errors)} skipped",
          file=sys.stderr)
    few = subset(samples, args.aam_images or None)
    extra = {"hold_out": args.hold_out_subjects, "fraction": args.train_fraction, "fit": args.fit,
             "split": data.split, "limit": args.limit, "aam_images": args.aam_images,
             "mirror": args.mirror,
             **({"update": args.update} if args.update != "jacobian" else {})}
    folders = ",".join(str(f) for f in data.folders)
    out = args.out or cache_dir() / f"{data.name}-{cache_key(folders, config, extra)}.npz"
    aam = train_aam(few, data.scheme, config, progress=bar("appearance model"),
                    source=args.data)
    aam.summary["skipped"] = data.errors + aam.summary["skipped"]
    if args.fit:
        print(f"training the fitters on {len(samples)} faces (box mapping, update matrices and "
              f"descent cascade on {len(few)}, local-binary cascade on all"
              f"{' and their mirror images' if args.mirror else ''})", file=sys.stderr)
        model = train_fitting_model(aam, samples, args.update, bar=bar, mirror=args.mirror,
                                    aam_images=args.aam_images or None)
        path = model.save(out)
    else:
        path = save_model(aam, out)
    print_summary(read_header(path), path)
    return 0
