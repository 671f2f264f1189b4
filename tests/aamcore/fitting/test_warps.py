"""aamcore.fitting.warps: the fitter's warp, made when something warps, counted per path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aamcore.fitting.warps import FitterWarp


@pytest.fixture(scope="module")
def faces(imm_set) -> list[tuple[np.ndarray, np.ndarray]]:
    return [(s.load_image(), s.points) for s in imm_set.samples if int(s.subject) >= 10][:2]


def test_nothing_is_made_before_a_warp_and_each_warp_is_counted(imm_model, faces) -> None:
    warp = FitterWarp(imm_model, "cpu")
    assert not warp.started and warp.path == "none" and warp.take_path() == "none"
    assert math.isnan(warp.ms_per_warp("cpu")) and warp.summary() == "warps gpu 0, cpu 0"
    image, points = faces[0]
    prepared = imm_model.prepare_image(image, points)
    texture = warp(prepared, points)
    np.testing.assert_array_equal(texture, imm_model.warp.warp(prepared, points))
    warp.warp(prepared, points)
    assert warp.started and warp.path == "cpu" and warp.counts == {"gpu": 0, "cpu": 2}
    assert warp.take_path() == "cpu" and warp.take_path() == "none"
    assert warp.ms_per_warp("cpu") > 0 and warp.summary().startswith("warps gpu 0, cpu 2 (")
    warp.close()


def test_the_gpu_path_warps_like_the_cpu(imm_model, faces) -> None:
    image, points = faces[0]
    prepared = imm_model.prepare_image(image, points)
    with pytest.raises(ValueError, match="prefer"):
        FitterWarp(imm_model, "tpu")  # type: ignore[arg-type]
    warp = FitterWarp(imm_model, "gpu")
    try:
        assert warp.start() == "gpu", "no GL context: the GPU path cannot be compared"
        texture = warp(prepared, points)
        assert warp.take_path() == "gpu" and warp.counts["gpu"] == 1
        assert np.abs(texture - imm_model.warp.warp(prepared, points)).mean() < 1.0
        # a shape the GL warp refuses (non-finite) gets the CPU's answer, the GPU path stays
        bad = points.copy()
        bad[0] = np.nan
        warp(prepared, bad)
        assert warp.path == "gpu" and warp.counts["cpu"] == 1
    finally:
        warp.close()
