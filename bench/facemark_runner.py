"""OpenCV FacemarkAAM side of ``bench/bench_facemark.py``, run in its own venv.

This script runs under a separate virtual environment holding
``opencv-contrib-python-headless`` (it cannot live beside the project's
``opencv-python-headless``: both install ``cv2``), so it imports only numpy
and cv2, never ``aamcore``. The bench talks to it through JSON files::

    python bench/facemark_runner.py train REQUEST.json RESULT.json
    python bench/facemark_runner.py fit REQUEST.json RESULT.json

Two facts about OpenCV's Python bindings shape what it does:

1. **No training from Python.** ``cv2.face.createFacemarkAAM()`` returns an
   object with ``fit`` and ``loadModel`` only: ``addTrainingSample`` and
   ``training`` are C++ only (opencv_contrib issue 2071; the pull request that
   would bind them, 2197, was never merged). ``train`` therefore compiles a
   small C++ program against the system's OpenCV contrib library (Debian:
   ``apt-get install libopencv-contrib-dev``) that feeds the training images
   to OpenCV's own ``FacemarkAAM::training`` and saves the model file, which
   the Python binding then loads with ``loadModel``.
2. **``fit`` ignores the face boxes.** ``Facemark.fit(image, faces)`` calls
   ``fitConfig`` with no configuration, which starts the mean shape ``s0`` at
   the image centre at the model's own scale, whatever the boxes say
   (``fitConfig``, the call that takes a start pose, is C++ only). To start
   from a box, ``fit`` maps the image with a similarity so that the start
   learned for that box (``k * s0 + c``) falls on ``s0`` at the centre of a
   canvas, fits there, and maps the landmarks back. The box-to-start mapping
   ``k = a * w``, ``c = centre + w * b`` is learned by least squares from the
   training images' Haar boxes, as aamtrack learns its own.

Request and result formats
--------------------------
``train`` request: ``{"model": path, "pixels": int, "samples": [{"image":
path, "points": [[x, y], ...]}], "boxes": [[x, y, w, h] or null, ...]}``
(0-based pixel coordinates); result: ``{"model", "s0", "mapping": {"a", "b"},
"scale", "reference_pixels", "train_seconds", "n_train", "trained_with",
"cached"}``.
The model and its ``.json`` side file are reused when they exist.

``fit`` request: ``{"model": path, "s0": [[x, y], ...], "mapping": {...},
"samples": [{"image": path, "box": [x, y, w, h]}]}``; result:
``{"landmarks": [[[x, y], ...], ...], "starts": [...], "seconds": [...],
"fit_seconds": [...], "opencv": version}``. ``seconds`` covers the canvas
warp and ``Facemark.fit``; ``fit_seconds`` the ``fit`` call alone.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

TRAINER_SOURCE = r"""
// Train OpenCV's FacemarkAAM (C++ only API) and save the model and mean shape.
#include <fstream>
#include <iostream>
#include <string>
#include <vector>
#include <opencv2/core.hpp>
#include <opencv2/face.hpp>
#include <opencv2/imgcodecs.hpp>

int main(int argc, char** argv) {
    if (argc != 5) {
        std::cerr << "usage: " << argv[0] << " LIST MODEL SCALE S0_OUT\n";
        return 2;
    }
    std::vector<cv::String> images;
    std::vector<std::vector<cv::Point2f> > points;
    if (!cv::face::loadTrainingData(argv[1], images, points, ' ', 0.0f) || images.empty()) {
        std::cerr << argv[1] << ": no training data could be read\n";
        return 1;
    }
    cv::face::FacemarkAAM::Params params;
    params.model_filename = argv[2];
    params.scales = std::vector<float>(1, std::stof(argv[3]));
    params.verbose = false;
    params.save_model = true;
    cv::Ptr<cv::face::FacemarkAAM> facemark = cv::face::FacemarkAAM::create(params);
    for (size_t i = 0; i < images.size(); ++i) {
        cv::Mat image = cv::imread(images[i], cv::IMREAD_GRAYSCALE);
        if (image.empty()) {
            std::cerr << images[i] << ": cannot read the image\n";
            return 1;
        }
        facemark->addTrainingSample(image, points[i]);
    }
    facemark->training();
    cv::face::FacemarkAAM::Data data;
    facemark->getData(&data);
    std::ofstream out(argv[4]);
    out.precision(9);
    for (const cv::Point2f& p : data.s0) out << p.x << ' ' << p.y << '\n';
    std::cout << CV_VERSION << '\n';
    return out ? 0 : 1;
}
"""

OPENCV_INCLUDE = Path("/usr/include/opencv4")
OPENCV_LIBS = (
    "-lopencv_face",
    "-lopencv_objdetect",
    "-lopencv_imgcodecs",
    "-lopencv_imgproc",
    "-lopencv_core",
)
INSTALL_HINT = (
    "OpenCV's Python binding cannot train FacemarkAAM, so the bench trains it through "
    "OpenCV's C++ API: install a C++ compiler and the OpenCV contrib headers and "
    "libraries (Debian/Ubuntu: `apt-get install g++ libopencv-contrib-dev`)"
)


class RunnerError(RuntimeError):
    """The runner cannot do what it was asked; the message says why."""


def build_trainer(folder: Path) -> Path:
    """Compile :data:`TRAINER_SOURCE` into ``folder`` (once per source version).

    Raises
    ------
    RunnerError
        If no compiler or no OpenCV face headers are found, or compiling fails.
    """
    digest = hashlib.sha256(TRAINER_SOURCE.encode()).hexdigest()[:12]
    binary = folder / f"facemark_aam_trainer-{digest}"
    if binary.is_file():
        return binary
    compiler = shutil.which("g++") or shutil.which("c++")
    if compiler is None or not (OPENCV_INCLUDE / "opencv2" / "face.hpp").is_file():
        raise RunnerError(INSTALL_HINT)
    folder.mkdir(parents=True, exist_ok=True)
    source = folder / f"facemark_aam_trainer-{digest}.cpp"
    source.write_text(TRAINER_SOURCE)
    command = [
        compiler,
        "-O2",
        "-std=c++17",
        str(source),
        "-o",
        str(binary),
        f"-I{OPENCV_INCLUDE}",
        *OPENCV_LIBS,
    ]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RunnerError(
            f"compiling the FacemarkAAM trainer failed:\n{done.stderr}\n{INSTALL_HINT}"
        )
    return binary


def training_list(samples: list[dict]) -> str:
    """Lines ``path x1 y1 ... xN yN`` as read by ``cv::face::loadTrainingData``.

    Raises
    ------
    RunnerError
        If an image path holds whitespace (the format separates by spaces).
    """
    lines = []
    for sample in samples:
        path = str(sample["image"])
        if any(ch.isspace() for ch in path):
            raise RunnerError(f"{path!r}: loadTrainingData cannot read paths with whitespace")
        coords = np.asarray(sample["points"], dtype=np.float64).reshape(-1)
        lines.append(path + " " + " ".join(f"{v:.4f}" for v in coords))
    return "\n".join(lines) + "\n"


def place_mean(s0: np.ndarray, points: np.ndarray) -> tuple[float, np.ndarray]:
    """Least-squares scale ``k`` and offset ``c`` with ``points ~ k * s0 + c``.

    Parameters
    ----------
    s0 : (N, 2) array
    points : (N, 2) array
    """
    a = s0 - s0.mean(axis=0)
    k = float(np.sum(a * (points - points.mean(axis=0))) / np.sum(a * a))
    return k, points.mean(axis=0) - k * s0.mean(axis=0)


def learn_mapping(s0: np.ndarray, samples: list[dict], boxes: list) -> dict:
    """Learn ``k = a * w`` and ``c = box centre + w * b`` from boxes and shapes.

    Parameters
    ----------
    s0 : (N, 2) array
        The model's mean shape.
    samples : list of dict
        Each with ``points`` (N, 2).
    boxes : list
        ``[x, y, w, h]`` or None per sample; samples without a box are left out.

    Raises
    ------
    RunnerError
        If fewer than two samples have a box.
    """
    widths, scales, offsets = [], [], []
    for sample, box in zip(samples, boxes, strict=True):
        if box is None:
            continue
        x, y, w, h = (float(v) for v in box)
        k, c = place_mean(s0, np.asarray(sample["points"], dtype=np.float64))
        widths.append(w)
        scales.append(k)
        offsets.append((c - [x + w / 2, y + h / 2]) / w)
    if len(widths) < 2:
        raise RunnerError("learning the box-to-start mapping needs at least two boxes")
    w, k = np.array(widths), np.array(scales)
    return {
        "a": float(np.sum(w * k) / np.sum(w * w)),
        "b": np.mean(offsets, axis=0).tolist(),
        "n": len(widths),
    }


def hull_pixels(points: np.ndarray) -> float:
    """Area of the convex hull of (N, 2) ``points``, in pixels."""
    return float(cv2.contourArea(cv2.convexHull(points.astype(np.float32))))


def initial_scale(samples: list[dict], pixels: int) -> float:
    """Model scale for a texture frame of about ``pixels`` pixels, before training.

    OpenCV's mean shape keeps the size of the plain mean of the centred
    training shapes, whose hull area this measures.
    """
    shapes = [np.asarray(s["points"], dtype=np.float64) for s in samples]
    mean = np.mean([p - p.mean(axis=0) for p in shapes], axis=0)
    return float(np.sqrt(hull_pixels(mean) / pixels))


def run_trainer(
    trainer: Path, listing: Path, model: Path, scale: float
) -> tuple[np.ndarray, float, str]:
    """Train and save one model at ``scale``.

    Returns
    -------
    s0 : (N, 2) array
        The model's mean shape.
    seconds : float
        Training time.
    version : str
        The C++ OpenCV version that trained it.
    """
    s0_file = listing.with_suffix(".s0")
    start = time.perf_counter()
    done = subprocess.run(
        [str(trainer), str(listing), str(model), repr(scale), str(s0_file)],
        capture_output=True,
        text=True,
        check=False,
    )
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RunnerError(f"FacemarkAAM training failed ({done.returncode}): {done.stderr}")
    return np.loadtxt(s0_file, dtype=np.float64).reshape(-1, 2), seconds, done.stdout.strip()


def train(request: dict) -> dict:
    """Train (or reuse) a FacemarkAAM model and learn its box-to-start mapping.

    The model's single scale is chosen so that the texture frame (the hull of
    ``s0 / scale``) holds about ``request["pixels"]`` pixels; when the first
    estimate misses by more than 2 %, the model is trained again at the
    exact scale (the mean shape does not depend on it).
    """
    model = Path(request["model"])
    side = model.with_suffix(".json")
    if model.is_file() and side.is_file():
        result = json.loads(side.read_text())
        result["cached"] = True
        return result
    samples, pixels = request["samples"], int(request["pixels"])
    if not samples or pixels < 100:
        raise RunnerError("train needs samples and at least 100 texture pixels")
    trainer = build_trainer(model.parent)
    scale = initial_scale(samples, pixels)
    with tempfile.TemporaryDirectory() as tmp:
        listing = Path(tmp) / "train.txt"
        listing.write_text(training_list(samples))
        s0, seconds, version = run_trainer(trainer, listing, model, scale)
        exact = float(np.sqrt(hull_pixels(s0) / pixels))
        if abs(exact / scale - 1.0) > 0.02:
            scale = exact
            s0, seconds, version = run_trainer(trainer, listing, model, scale)
    result = {
        "model": str(model),
        "s0": s0.tolist(),
        "mapping": learn_mapping(s0, samples, request["boxes"]),
        "scale": scale,
        "reference_pixels": round(hull_pixels(s0 / scale)),
        "train_seconds": seconds,
        "n_train": len(samples),
        "trained_with": f"C++ OpenCV {version}",
    }
    side.write_text(json.dumps(result))
    result["cached"] = False
    return result


def canvas_for(s0: np.ndarray) -> int:
    """Side of the square canvas that holds ``s0`` centred with a wide margin."""
    extent = float(np.max(np.abs(s0 - s0.mean(axis=0))))
    return 2 * int(np.ceil(2.0 * extent))


def box_to_canvas(box: np.ndarray, mapping: dict, side: int) -> np.ndarray:
    """2x3 similarity taking image pixels to the canvas where ``fit`` starts.

    ``fit`` places ``s0`` at the canvas centre ``side / 2``; the learned start
    for ``box`` is ``k * s0 + c``, so image point ``p`` maps to
    ``(p - c) / k + side / 2``.
    """
    x, y, w, h = (float(v) for v in box)
    k = mapping["a"] * w
    c = np.array([x + w / 2, y + h / 2]) + w * np.asarray(mapping["b"])
    centre = side / 2.0
    return np.array([[1 / k, 0.0, centre - c[0] / k], [0.0, 1 / k, centre - c[1] / k]])


def fit(request: dict) -> dict:
    """Fit every requested image from its box with ``Facemark.fit``."""
    cv2.setNumThreads(int(request.get("threads", 1)))
    facemark = cv2.face.createFacemarkAAM()
    facemark.loadModel(str(request["model"]))
    s0 = np.asarray(request["s0"], dtype=np.float64)
    side = canvas_for(s0)
    start_canvas = s0 + side / 2.0
    landmarks, starts, seconds, fit_seconds = [], [], [], []
    for sample in request["samples"]:
        image = cv2.imread(str(sample["image"]), cv2.IMREAD_COLOR)
        if image is None:
            raise RunnerError(f"{sample['image']}: cannot read the image")
        t0 = time.perf_counter()
        m = box_to_canvas(np.asarray(sample["box"]), request["mapping"], side)
        canvas = cv2.warpAffine(image, m, (side, side), flags=cv2.INTER_LINEAR)
        corner = m[:, :2] @ np.asarray(sample["box"][:2], dtype=np.float64) + m[:, 2]
        size = np.asarray(sample["box"][2:], dtype=np.float64) * m[0, 0]
        faces = np.array([[*np.round(corner), *np.round(size)]], dtype=np.int32)
        t1 = time.perf_counter()
        ok, found = facemark.fit(canvas, faces)
        t2 = time.perf_counter()
        if not ok:
            raise RunnerError(f"{sample['image']}: Facemark.fit returned False")
        points = np.asarray(found[0], dtype=np.float64).reshape(-1, 2)
        back = cv2.invertAffineTransform(m)
        landmarks.append((points @ back[:, :2].T + back[:, 2]).tolist())
        starts.append((start_canvas @ back[:, :2].T + back[:, 2]).tolist())
        seconds.append(t2 - t0)
        fit_seconds.append(t2 - t1)
    return {
        "landmarks": landmarks,
        "starts": starts,
        "seconds": seconds,
        "fit_seconds": fit_seconds,
        "opencv": cv2.__version__,
        "canvas": side,
    }


COMMANDS = {"train": train, "fit": fit}


def main(argv: list[str]) -> int:
    """Run ``COMMAND REQUEST.json RESULT.json``; errors go to stderr, exit status 1."""
    if len(argv) != 3 or argv[0] not in COMMANDS:
        print(f"usage: facemark_runner.py {{{','.join(COMMANDS)}}} REQUEST.json RESULT.json",
              file=sys.stderr)
        return 2
    if not hasattr(cv2, "face"):
        print(f"this cv2 ({cv2.__version__}, {cv2.__file__}) has no `face` module: run me with "
              "opencv-contrib-python-headless", file=sys.stderr)
        return 1
    try:
        result = COMMANDS[argv[0]](json.loads(Path(argv[1]).read_text()))
    except (RunnerError, OSError, KeyError, ValueError, cv2.error) as exc:
        print(f"facemark_runner {argv[0]}: {exc}", file=sys.stderr)
        return 1
    Path(argv[2]).write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
