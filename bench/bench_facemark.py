"""Compare aamtrack's fitter with OpenCV's ``cv2.face.createFacemarkAAM`` on LFPW.

Run: ``python -m bench facemark [--limit N]``

Protocol (as aamtrack's own LFPW bench): ``lfpw/trainset`` sorted by file
name, the first 80 % train both models, the last 20 % are fitted. Both
fitters start from the same Haar box (the detection matching the annotated
face; images where Haar misses it are skipped and counted). NME is the mean
point error over the outer-eye-corner distance (iBUG 36 and 45). Both sides
run on one thread.

- aamtrack: ``train_aam(train, TrainConfig(colour=False,
  shape_variance=0.98))`` then ``train_fitting_model(..., max_images=30)``,
  cached under ``cache_dir()`` keyed by the split; fitted with
  ``Fitter(aam, algorithm).fit_box(image, box)`` for ``supervised-descent``
  and ``fixed-jacobian``.
- OpenCV: ``opencv-contrib-python-headless`` lives in its own venv
  (``cache_dir()/facemark-venv``, made on first use) because it clashes with
  the project's ``opencv-python-headless``; ``bench/facemark_runner.py`` runs
  there. OpenCV's Python binding can neither train FacemarkAAM nor start
  ``fit`` from a box, so the runner trains through OpenCV's C++ API (needs
  ``g++`` and ``libopencv-contrib-dev``) and starts the fit from a box by
  mapping the image so that the start learned for the box falls where ``fit``
  starts; see that file. The texture frame is scaled to about as many pixels
  as aamtrack's (``--opencv-pixels``). ``fit`` runs OpenCV's default
  parameters (50 iterations, 10 shape and up to 200 texture modes): the
  binding cannot change them.

Prints a table of both methods side by side with the ratios, then the lines
``RATIO NME aamtrack/opencv: X`` and ``RATIO time aamtrack/opencv: Y``
(aamtrack's supervised-descent fitter, mean NME and median time per fit).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from threadpoolctl import threadpool_limits

from aamcore.config import cache_dir, resolve_dataset
from aamcore.detection.haar import HaarFaceDetector
from aamcore.evaluation.fits import haar_box
from aamcore.evaluation.metrics import nme, summarise
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.training.prepare import train_fitting_model
from aamcore.io import FaceSample, load_annotated_folder
from aamcore.io.landmarks import LandmarkScheme
from aamcore.model.cache import cache_key, cached_file
from aamcore.model.training import TrainConfig, train_aam
from bench import options
from bench.targets import Target

NME_RATIO = Target("mean NME, aamtrack / OpenCV FacemarkAAM", "<=", 1.0, "x")
TIME_RATIO = Target("median time per fit, aamtrack / OpenCV FacemarkAAM", "<=", 1.0, "x")
TARGETS = (NME_RATIO, TIME_RATIO)

RUNNER = Path(__file__).resolve().parent / "facemark_runner.py"
REQUIREMENTS = ("opencv-contrib-python-headless>=4.10,<5", "numpy")
TRAIN_FRACTION = 0.8
ALGORITHMS = ("supervised-descent", "fixed-jacobian")
AAMTRACK_CONFIG = TrainConfig(colour=False, shape_variance=0.98)
UPDATE_IMAGES = 30


@dataclass
class MethodResult:
    """Fits of one method on the test images that Haar found.

    Attributes
    ----------
    name : str
    nme : (M,) array
        NME per image (NaN for a fit that raised).
    start_nme : (M,) array
        NME of the start shape placed in the box.
    seconds : (M,) array
        Time per fit from the box.
    """

    name: str
    nme: np.ndarray
    start_nme: np.ndarray
    seconds: np.ndarray


def lfpw_split() -> tuple[list[FaceSample], list[FaceSample], LandmarkScheme]:
    """First 80 % (by file name) of ``lfpw/trainset`` to train, the rest to test."""
    data = load_annotated_folder(resolve_dataset("lfpw"))
    samples = sorted(data.samples, key=lambda s: s.image_path.name)
    cut = int(round(TRAIN_FRACTION * len(samples)))
    return samples[:cut], samples[cut:], data.scheme


def split_name(train: list[FaceSample], total: int) -> str:
    """Name of the split in cache keys: the count and a hash of the train file names."""
    digest = hashlib.sha256("\n".join(s.image_path.name for s in train).encode()).hexdigest()
    return f"first {len(train)} of {total} by name ({digest[:10]})"


def aamtrack_model(train: list[FaceSample], total: int) -> FittingModel:
    """aamtrack's model on the train split, trained once and cached."""
    folder = resolve_dataset("lfpw")
    key = cache_key(str(folder), AAMTRACK_CONFIG, {"select": split_name(train, total),
                                                  "prepare": f"{UPDATE_IMAGES} images"})

    def build(path: Path) -> Path:
        samples = sorted(train, key=lambda s: s.image_path.name)
        aam = train_aam(samples, load_annotated_folder(folder).scheme, AAMTRACK_CONFIG)
        return train_fitting_model(aam, samples, max_images=UPDATE_IMAGES).save(path)

    return FittingModel.load(cached_file(cache_dir() / f"facemark-{key}.npz", build,
                                         FittingModel.load))


def haar_boxes(detector: HaarFaceDetector, samples: list[FaceSample]) -> list[np.ndarray | None]:
    """The Haar detection matching each sample's face, or None where Haar misses it."""
    return [haar_box(detector, s.load_image(), s.points) for s in samples]


def facemark_python(venv: Path) -> Path:
    """Python of the venv holding opencv-contrib-python-headless, made on first use.

    Raises
    ------
    RuntimeError
        If the venv cannot be created or the packages cannot be installed.
    """
    python = venv / "bin" / "python"
    check = [str(python), "-c", "import cv2; cv2.face.createFacemarkAAM"]
    if python.is_file() and subprocess.run(check, capture_output=True).returncode == 0:
        return python
    print(f"creating {venv} with {', '.join(REQUIREMENTS)} ...", file=sys.stderr)
    steps = [
        [sys.executable, "-m", "venv", str(venv)],
        [str(python), "-m", "pip", "install", "--quiet", *REQUIREMENTS],
    ]
    for step in steps:
        done = subprocess.run(step, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"`{' '.join(step)}` failed:\n{done.stderr}")
    if subprocess.run(check, capture_output=True).returncode != 0:
        raise RuntimeError(f"{python}: cv2.face is still missing after installing")
    return python


def run_runner(python: Path, command: str, request: dict) -> dict:
    """Run ``facemark_runner.py COMMAND`` in the other venv; return its JSON result.

    Raises
    ------
    RuntimeError
        With the runner's error message if it fails.
    """
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        req, res = Path(tmp) / "request.json", Path(tmp) / "result.json"
        req.write_text(json.dumps(request))
        done = subprocess.run(
            [str(python), str(RUNNER), command, str(req), str(res)],
            capture_output=True,
            text=True,
            env=env,
        )
        if done.returncode != 0:
            raise RuntimeError(f"facemark_runner {command} failed:\n{done.stderr.strip()}")
        return json.loads(res.read_text())


def opencv_model(
    python: Path, train: list[FaceSample], total: int, pixels: int, detector: HaarFaceDetector
) -> dict:
    """Train (once, cached) OpenCV's FacemarkAAM on ``train`` through the runner.

    The texture frame holds about ``pixels`` pixels. Haar boxes of the train
    images (for the runner's box-to-start mapping) are found only when the
    model is not cached yet.
    """
    runner_hash = hashlib.sha256(RUNNER.read_bytes()).hexdigest()[:10]
    key = hashlib.sha256(f"{split_name(train, total)}|{pixels}|{runner_hash}".encode())
    model = cache_dir() / f"facemark-aam-{key.hexdigest()[:12]}.yaml"
    boxes: list[np.ndarray | None] = []
    if not (model.is_file() and model.with_suffix(".json").is_file()):
        print(f"training OpenCV FacemarkAAM on {len(train)} images ...", file=sys.stderr)
        boxes = haar_boxes(detector, train)
    request = {
        "model": str(model),
        "pixels": pixels,
        "samples": [{"image": str(s.image_path), "points": s.points.tolist()} for s in train],
        "boxes": [None if b is None else b.tolist() for b in boxes],
    }
    return run_runner(python, "train", request)


def fit_aamtrack(
    model: FittingModel,
    algorithm: str,
    samples: list[FaceSample],
    boxes: list[np.ndarray],
    scheme: LandmarkScheme,
) -> MethodResult:
    """Fit every sample from its box with aamtrack's ``algorithm``."""
    fitter = Fitter(model, algorithm)
    errors, starts, seconds = [], [], []
    for sample, box in zip(samples, boxes, strict=True):
        image = sample.load_image()
        starts.append(nme(fitter.mapping.place(box, "detector"), sample.points, scheme))
        t0 = time.perf_counter()
        try:
            result = fitter.fit_box(image, box)
            points = result.points
        except (ValueError, np.linalg.LinAlgError):
            points = None
        seconds.append(time.perf_counter() - t0)
        ok = points is not None and np.all(np.isfinite(points))
        errors.append(nme(points, sample.points, scheme) if ok else np.nan)
    return MethodResult(
        f"aamtrack {algorithm}", np.array(errors), np.array(starts), np.array(seconds)
    )


def fit_opencv(
    python: Path,
    model: dict,
    samples: list[FaceSample],
    boxes: list[np.ndarray],
    scheme: LandmarkScheme,
) -> MethodResult:
    """Fit every sample from its box with OpenCV's FacemarkAAM (in the runner)."""
    request = {
        "model": model["model"],
        "s0": model["s0"],
        "mapping": model["mapping"],
        "threads": 1,
        "samples": [
            {"image": str(s.image_path), "box": b.tolist()}
            for s, b in zip(samples, boxes, strict=True)
        ],
    }
    result = run_runner(python, "fit", request)
    errors = [
        nme(np.array(p), s.points, scheme)
        for p, s in zip(result["landmarks"], samples, strict=True)
    ]
    starts = [
        nme(np.array(p), s.points, scheme) for p, s in zip(result["starts"], samples, strict=True)
    ]
    return MethodResult(
        f"OpenCV FacemarkAAM {result['opencv']}",
        np.array(errors),
        np.array(starts),
        np.array(result["seconds"]),
    )


def metrics(result: MethodResult) -> dict[str, float]:
    """Table values of one method: NME statistics and median time per fit in ms."""
    summary = summarise(result.nme)
    return {
        "NME mean": summary.mean,
        "NME median": summary.median,
        "failure NME > 0.08": summary.failure_008,
        "failure NME > 0.10": summary.failure_010,
        "time per fit, median ms": float(np.median(result.seconds) * 1e3),
        "time per fit, p90 ms": float(np.percentile(result.seconds, 90) * 1e3),
        "start NME mean": float(np.mean(result.start_nme)),
    }


def ratio(a: float, b: float) -> float:
    """``a / b``, NaN when ``b`` is 0."""
    return a / b if b else float("nan")


def print_table(aamtrack: list[MethodResult], opencv: MethodResult) -> None:
    """Rows of metrics; columns: OpenCV, then each aamtrack fitter and its ratio to OpenCV."""
    ref = metrics(opencv)
    rows = [metrics(r) for r in aamtrack]
    names = ["OpenCV AAM"] + [r.name.removeprefix("aamtrack ") for r in aamtrack]
    header = f"{'':<26}{names[0]:>12}"
    for name in names[1:]:
        header += f"{name:>20}{'/OpenCV':>9}"
    print(header)
    for key in ref:
        line = f"{key:<26}{ref[key]:>12.4g}"
        for row in rows:
            line += f"{row[key]:>20.4g}{ratio(row[key], ref[key]):>9.3f}"
        print(line)


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--limit", type=int, help="fit only the first N test images (quick run)")
    parser.add_argument("--opencv-pixels", type=int,
                        help="texture pixels of the OpenCV model (default: as aamtrack's)")
    args = options.parse(parser, argv)
    if args.limit is not None and args.limit < 1:
        parser.error("--limit must be >= 1")
    cv2.setNumThreads(1)
    start = time.perf_counter()
    train, test, scheme = lfpw_split()
    total = len(train) + len(test)
    test = test[: args.limit] if args.limit else test
    detector = HaarFaceDetector()
    ours_model = aamtrack_model(train, total)
    python = facemark_python(cache_dir() / "facemark-venv")
    pixels = args.opencv_pixels or ours_model.aam.frame.n_pixels
    model = opencv_model(python, train, total, pixels, detector)

    found = [(s, b) for s, b in zip(test, haar_boxes(detector, test), strict=True) if b is not None]
    samples, boxes = [s for s, _ in found], [b for _, b in found]
    with threadpool_limits(limits=1):
        ours = [fit_aamtrack(ours_model, a, samples, boxes, scheme) for a in ALGORITHMS]
    theirs = fit_opencv(python, model, samples, boxes, scheme)

    print(
        f"LFPW trainset, {total} images sorted by name: {len(train)} train, "
        f"{len(test)} test; Haar missed {len(test) - len(samples)} test faces "
        f"(skipped), fitted {len(samples)}; one thread"
    )
    print(
        f"aamtrack: grey, {ours_model.aam.frame.n_pixels} reference px, "
        f"{ours_model.aam.shape.n_modes} shape / {ours_model.aam.n_appearance} appearance modes"
    )
    cached = "cached" if model["cached"] else f"trained in {model['train_seconds']:.0f} s"
    print(
        f"{theirs.name}: {model['reference_pixels']} reference px (scale {model['scale']:.3f}), "
        f"model from {model['trained_with']} ({cached}), box-to-start mapping from "
        f"{model['mapping']['n']} train boxes; fit with default params (50 iterations)"
    )
    print()
    print_table(ours, theirs)
    best, ref = metrics(ours[0]), metrics(theirs)
    nme_ratio = ratio(best["NME mean"], ref["NME mean"])
    time_ratio = ratio(best["time per fit, median ms"], ref["time per fit, median ms"])
    print(f"\nbench {time.perf_counter() - start:.0f} s")
    ok = NME_RATIO.check(nme_ratio, f"{ALGORITHMS[0]}, the same split")
    return 0 if TIME_RATIO.check(time_ratio, f"{ALGORITHMS[0]}") and ok else 1

