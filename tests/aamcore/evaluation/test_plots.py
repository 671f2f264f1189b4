"""PNG figures: CED curves and displacement plots, read back with OpenCV."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.evaluation.plots import save_ced_png, save_displacement_plot


def _read_back(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert image is not None, f"{path} is not a readable PNG"
    return image


def test_ced_png(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    curves = {"good": rng.gamma(4, 0.01, 200), "bad": np.append(rng.gamma(4, 0.03, 199), np.nan)}
    path = save_ced_png(curves, tmp_path / "sub" / "ced.png", title="test")
    image = _read_back(path)
    assert image.shape == (450, 600, 3)
    # Two coloured curves: the default cycle's blue and orange are both present.
    b, g, r = (image[..., k].astype(int) for k in range(3))
    assert np.count_nonzero((b > 150) & (r < 80)) > 100
    assert np.count_nonzero((r > 200) & (b < 80)) > 100


def test_ced_png_rejects_empty(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no curves"):
        save_ced_png({}, tmp_path / "x.png")
    with pytest.raises(ValueError, match="max_error"):
        save_ced_png({"a": [0.1]}, tmp_path / "x.png", max_error=0)


def test_displacement_plot(tmp_path: Path) -> None:
    offsets = np.array([-20, -10, 0, 10, 20])
    rng = np.random.default_rng(2)
    trials = np.abs(offsets)[:, None] * 0.3 + rng.normal(5, 1, (5, 8))
    trials[0, :] = np.nan  # every trial failed at one offset
    results = {
        "point to point (px)": {"x": trials, "y": trials * 1.2},
        "point to border (px)": {"x": trials * 0.7, "y": trials * 0.8},
        "avg Procrustes (px)": {"x": trials * 0.5},
    }
    path = save_displacement_plot(offsets, results, tmp_path / "disp.png", title="CoG start")
    image = _read_back(path)
    assert image.shape == (800, 1100, 3)
    assert image.std() > 10
    with pytest.raises(ValueError, match="no metrics"):
        save_displacement_plot(offsets, {}, tmp_path / "y.png")
