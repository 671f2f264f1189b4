"""Benchmark model training and the piecewise-affine warp (issue: AAM models).

Run: ``python -m bench models``

Prints training time and model size for IMM Frontal and the 805 LFPW images,
and the warp time into the reference frame from a 640x480 colour frame at about
10k and 30k reference pixels, against the targets (train LFPW under 90 s; warp under
0.5 ms at about 10k pixels).
"""

from __future__ import annotations

import os
import tempfile
import time

import cv2
import numpy as np

from aamcore.config import resolve_dataset
from aamcore.io import load_annotated_folder
from aamcore.model.file import save_model
from aamcore.model.training import TrainConfig, train_aam
from bench import options
from bench.targets import Target

TRAIN_LFPW = Target("train the AAM on LFPW's 805 images", "<", 90.0, "s")
WARP_10K = Target("warp into a ~10k-pixel reference frame from 640x480", "<", 0.5, "ms")
TARGETS = (TRAIN_LFPW, WARP_10K)


def bench_training() -> float:
    print(
        f"{'dataset':<12}{'images':>7}{'pixels':>8}{'t_s':>5}{'t_g':>5}{'t_c':>5}"
        f"{'train s':>9}{'file MB':>9}"
    )
    lfpw_time = float("nan")
    for name in ("imm_frontal", "lfpw"):
        data = load_annotated_folder(resolve_dataset(name))
        start = time.perf_counter()
        aam = train_aam(data.samples, data.scheme, TrainConfig())
        seconds = time.perf_counter() - start
        with tempfile.TemporaryDirectory() as tmp:
            size = save_model(aam, os.path.join(tmp, "m.npz")).stat().st_size / 1e6
        print(
            f"{name:<12}{len(data.samples):>7}{aam.frame.n_pixels:>8}{aam.shape.n_modes:>5}"
            f"{aam.texture.n_modes:>5}{aam.n_appearance:>5}{seconds:>9.2f}{size:>9.1f}"
        )
        if name == "lfpw":
            lfpw_time = seconds
    return lfpw_time


def bench_warp() -> dict[int, float]:
    data = load_annotated_folder(resolve_dataset("lfpw"), limit=200)
    sample = data.samples[0]
    image = sample.load_image()
    sx, sy = 640 / image.shape[1], 480 / image.shape[0]
    frame = cv2.resize(image, (640, 480))
    points = sample.points * [sx, sy]
    results = {}
    print(f"\n{'target px':>10}{'actual px':>10}{'warp ms (median)':>18}{'p90 ms':>8}")
    for target in (10_000, 30_000):
        aam = train_aam(data.samples, data.scheme, TrainConfig(n_pixels=target))
        warp = aam.warp
        for _ in range(20):
            warp.warp(frame, points)
        times = []
        for _ in range(500):
            t0 = time.perf_counter()
            warp.warp(frame, points)
            times.append(time.perf_counter() - t0)
        ms = np.array(times) * 1e3
        results[target] = float(np.median(ms))
        print(f"{target:>10}{warp.n_pixels:>10}{np.median(ms):>18.3f}{np.percentile(ms, 90):>8.3f}")
    return results


def main(argv: list[str] | None = None) -> int:
    options.parse(options.parser(__doc__, __name__), argv)
    cv2.setNumThreads(2)
    lfpw = bench_training()
    warp = bench_warp()
    ok = TRAIN_LFPW.check(lfpw) & WARP_10K.check(warp[10_000], "median")
    return 0 if ok else 1

