"""``aamtrack model prepare|show|modes|reconstruct``: ready the default models, look at one."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from services.cli.commands import add_command


def register(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "model")
    msub = p.add_subparsers(dest="model_command", required=True, metavar="ACTION")
    prep = msub.add_parser(
        "prepare", help="train a profile's models now (else the first run does): the fitting "
        "model and the expression classifier for its fits"
    )
    from aamcore.profiles import PROFILES

    prep.add_argument("--profile", choices=tuple(PROFILES), default="default",
                      help="the pipeline whose models to train (default: default; thesis: the "
                      "update matrices of the fixed-Jacobian AAM and LDA + Mahalanobis on c)")
    prep.add_argument("--algorithm", help="the fitting algorithm whose fits the classifier "
                      "reads (default: the profile's)")
    prep.add_argument("--update", choices=("jacobian", "regression"),
                      help="how the model's update matrices are learned (default: the "
                      "profile's, jacobian)")
    prep.add_argument("--limit", type=int, default=None,
                      help="train on the first N images only (a small model, as --model-limit)")
    prep.add_argument("--update-images", type=int, default=None,
                      help="images for the update matrices (as the fitter's --model-images)")
    prep.add_argument("--no-classifier", action="store_true",
                      help="the fitting model only, not the expression classifier")
    prep.set_defaults(func=run_prepare)
    show = msub.add_parser("show", help="print a model's summary")
    show.add_argument("file", type=Path, help="a model file (.npz)")
    show.set_defaults(func=run_show)
    modes = msub.add_parser("modes", help="render the +-3 sd variation of the first modes")
    modes.add_argument("file", type=Path, help="a model file (.npz)")
    modes.add_argument("--out", type=Path, required=True, help="PNG to write")
    modes.add_argument("--modes", type=int, default=3, help="modes per model (default 3)")
    modes.set_defaults(func=run_modes)
    rec = msub.add_parser("reconstruct", help="show an image beside its model reconstruction")
    rec.add_argument("file", type=Path, help="a model file (.npz)")
    rec.add_argument("image", type=Path, help="the face's image")
    rec.add_argument("landmarks", type=Path, help=".pts or .asf file")
    rec.add_argument("--out", type=Path, required=True, help="PNG to write")
    rec.set_defaults(func=run_reconstruct)


def print_summary(header: dict[str, Any], path: Path) -> None:
    """Print the modes, variance and training facts of a model header."""
    modes, kept = header["modes"], header["variance_kept"]
    summary = header.get("summary", {})
    print(f"model {path}")
    print(
        f"  format version {header['format_version']}, scheme {header['scheme']['name']} "
        f"({header['scheme']['n_points']} points)"
    )
    print(
        f"  reference frame {header['reference']['size'][1]}x{header['reference']['size'][0]}"
        f", {header['reference']['pixels']} pixels, "
        f"{'colour' if header['channels'] == 3 else 'grey'}"
        f"{', equalised' if header['equalise'] else ''}"
    )
    print(f"  {'model':<10}{'modes':>7}{'variance':>10}")
    for name in ("shape", "texture", "combined"):
        print(f"  {name:<10}{modes[name]:>7}{kept[name]:>10.1%}")
    if summary:
        print(
            f"  trained on {summary.get('images')} images "
            f"({summary.get('subjects', 0)} subjects) from {summary.get('source')}, "
            f"{len(summary.get('skipped', []))} skipped"
        )
    for name, info in header.get("attachments", {}).items():
        print(f"  attachment {name}: {info}")
    extra = header.get("extra", {})
    if extra.get("kind") == "fitting":
        binary = extra.get("binary")
        print(f"  fitting part: {len(extra.get('updates', []))} update matrices, descent "
              f"cascade {'yes' if extra.get('cascade') else 'no'}, local-binary cascade "
              + (f"{binary['coarse']} coarse + {binary['tracking']} fern stages + "
                 f"{binary.get('restart', 0)} restart stages, failure "
                 f"threshold {binary['threshold']:.2f}, trained on "
                 f"{binary.get('report', {}).get('faces')} faces"
                 if binary else "no"))


def run_prepare(args: argparse.Namespace) -> int:
    """Train (or find in the cache) the models ``aamtrack run --profile P`` uses."""
    from aamcore.profiles import classifier_path, model_path, profile_named
    from aamcore.settings import ConfigError

    values = {"model_update": args.update, "model_images": args.update_images,
              "model_limit": args.limit, "algorithm": args.algorithm}
    try:
        options = profile_named(args.profile).options.with_values(
            **{k: v for k, v in values.items() if v})
    except ConfigError as exc:
        print(f"aamtrack model prepare: error: {exc}", file=sys.stderr)
        return 2
    model = model_path(options.model)
    print(f"fitting model {model}")
    if not args.no_classifier:
        print(f"expression classifier ({options.expression.features} features, "
              f"{options.fit.fitting.algorithm} fits) {classifier_path(model, options)}")
    return 0


def run_show(args: argparse.Namespace) -> int:
    from aamcore.model.file import read_header

    print_summary(read_header(args.file), args.file)
    return 0


def run_modes(args: argparse.Namespace) -> int:
    import cv2

    from aamcore.model.file import load_model
    from aamcore.model.visualise import modes_figure

    figure = modes_figure(load_model(args.file), args.modes)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), figure)
    print(f"wrote {args.out}")
    return 0


def load_landmarks(path: Path, image_size: tuple[int, int]) -> Any:
    """Landmarks (N, 2) in pixels from a ``.pts`` or ``.asf`` file."""
    from aamcore.io import read_asf, read_pts

    if path.suffix == ".asf":
        return read_asf(path).pixels(*image_size)
    return read_pts(path)


def run_reconstruct(args: argparse.Namespace) -> int:
    import cv2

    from aamcore.io import read_image
    from aamcore.model.file import load_model
    from aamcore.model.visualise import reconstruction_figure

    aam = load_model(args.file)
    image = read_image(args.image)
    points = load_landmarks(args.landmarks, (image.shape[1], image.shape[0]))
    if len(points) != aam.scheme.n_points:
        raise ValueError(
            f"{args.landmarks}: {len(points)} points, the model's scheme "
            f"{aam.scheme.name} has {aam.scheme.n_points}"
        )
    figure = reconstruction_figure(aam, image, points)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), figure)
    print(f"wrote {args.out}")
    return 0
