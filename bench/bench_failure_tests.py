"""Which fits does each failure test flag: eq. 7.2 against the chi-square test.

Run: ``.venv/bin/python bench/bench_failure_tests.py``

1. LFPW test split (the model of ``bench_fit_lfpw.py``), supervised descent
   from the Haar box: fits flagged by each test, and how many of them are real
   failures (NME > 0.10).
2. ``videos/single_face.mp4`` tracked with the stack's model: flagged frames
   and re-detections per algorithm and test.
No target: the table is the evidence behind the fitter service's default.
"""

from __future__ import annotations

import numpy as np
from bench_fit_lfpw import split_model

from aamcore.config import data_root, resolve_dataset
from aamcore.detection.haar import HaarFaceDetector
from aamcore.evaluation.fits import haar_box
from aamcore.evaluation.metrics import nme
from aamcore.fitting.failure import FAILURE_TESTS
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.tracker import Tracker
from aamcore.fitting.training.prepare import default_model_path
from aamcore.io import load_annotated_folder
from aamcore.io.video import video_frames


def lfpw_table() -> None:
    data = load_annotated_folder(resolve_dataset("lfpw"))
    cut = int(0.8 * len(data.samples))
    model = split_model(data.samples[:cut], data.scheme)
    detector = HaarFaceDetector()
    fitters = {kind: Fitter(model, failure_test=kind) for kind in FAILURE_TESTS}
    flags = {kind: [] for kind in FAILURE_TESTS}
    bad = []
    for sample in data.samples[cut:]:
        image = sample.load_image()
        box = haar_box(detector, image, sample.points)
        if box is None:
            continue
        for kind, fitter in fitters.items():
            result = fitter.fit_box(image, box)
            flags[kind].append(result.failed)
        bad.append(nme(result.points, sample.points, data.scheme) > 0.10)
    bad_arr = np.array(bad)
    print(f"LFPW test split, {len(bad)} fits from the Haar box, {bad_arr.sum()} with NME > 0.10")
    print(f"{'test':<8}{'flagged':>9}{'real failures flagged':>23}{'good fits flagged':>19}")
    for kind, f in flags.items():
        f_arr = np.array(f)
        real, good = (f_arr & bad_arr).sum(), (f_arr & ~bad_arr).sum()
        print(f"{kind:<8}{f_arr.sum():>9}{real:>23}{good:>19}")


def video_table() -> None:
    frames = video_frames(data_root() / "videos" / "single_face.mp4")
    model = FittingModel.load(default_model_path())
    print(f"\nsingle_face.mp4, {len(frames)} frames tracked with the stack's model")
    print(f"{'algorithm':<20}{'test':<8}{'flagged':>9}{'detections':>12}")
    for algorithm in ("supervised-descent", "fixed-jacobian"):
        for kind in FAILURE_TESTS:
            tracker = Tracker(Fitter(model, algorithm, failure_test=kind))
            flagged = sum(r is not None and r.failed for r in map(tracker.track, frames))
            print(f"{algorithm:<20}{kind:<8}{flagged:>9}{tracker.detections:>12}")


if __name__ == "__main__":
    lfpw_table()
    video_table()
