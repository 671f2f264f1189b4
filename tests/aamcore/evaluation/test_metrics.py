"""Fit metrics (eqs 7.4-7.7) and error statistics on real IMM and LFPW shapes."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from aamcore.config import data_root
from aamcore.evaluation import metrics
from aamcore.io import AnnotatedSet, load_annotated_folder
from aamcore.io.landmarks import IBUG68, generic_scheme
from aamcore.model.similarity import Similarity


@pytest.fixture(scope="module")
def lfpw_shapes(lfpw_dir: Path) -> np.ndarray:
    return np.stack([s.points for s in load_annotated_folder(lfpw_dir, limit=10).samples])


@functools.cache
def _lfpw_first_shape() -> np.ndarray:
    folder = data_root() / "lfpw" / "trainset"
    return load_annotated_folder(folder, limit=1).samples[0].points


def _similar(
    points: np.ndarray, scale: float, angle: float, shift: tuple[float, float]
) -> np.ndarray:
    return Similarity.from_scale_angle(scale, angle, shift).apply(points)


def test_point_to_point_self_and_translation(imm_set: AnnotatedSet) -> None:
    gt = imm_set.samples[0].points
    assert metrics.point_to_point(gt, gt) == 0.0
    assert metrics.point_to_point(gt + [3.0, 4.0], gt) == pytest.approx(5.0)
    np.testing.assert_allclose(metrics.point_errors(gt - [0.0, 2.0], gt), 2.0)


def test_procrustes_distance_ignores_similarity(lfpw_shapes: np.ndarray) -> None:
    gt, other = lfpw_shapes[0], lfpw_shapes[1]
    base = metrics.procrustes_distance(other, gt)
    assert base > 1.0
    for scale, angle, shift in [(0.5, 0.3, (40.0, -7.0)), (2.0, -1.2, (-100.0, 3.0))]:
        moved = _similar(other, scale, angle, shift)
        assert metrics.procrustes_distance(moved, gt) == pytest.approx(base, rel=1e-9)
        assert metrics.procrustes_distance(_similar(gt, scale, angle, shift), gt) < 1e-9
    assert base < metrics.point_to_point(other, gt)


def test_point_to_border_ignores_sliding_along_contour(imm_set: AnnotatedSet) -> None:
    gt = imm_set.samples[0].points
    scheme = imm_set.scheme
    successor = {a: b for a, b in scheme.edges}
    slid = gt.copy()
    for a, b in successor.items():
        slid[a] = gt[a] + 0.4 * (gt[b] - gt[a])
    on_edges = np.array(sorted(successor))
    border = metrics.point_to_border_errors(slid, gt, scheme)
    point = metrics.point_errors(slid, gt)
    np.testing.assert_allclose(border[on_edges], 0.0, atol=1e-9)
    assert point[on_edges].min() > 0.5
    assert metrics.point_to_border(slid, gt, scheme) < 0.2 * metrics.point_to_point(slid, gt)


def test_point_to_border_measures_normal_distance() -> None:
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [50.0, 50.0]])
    edges = [(0, 1), (1, 2), (2, 3), (3, 0)]
    fit = square.copy()
    fit[0] = [4.0, -3.0]  # 3 px outside the bottom side, slid 4 px along it
    fit[1] = [13.0, 14.0]  # beyond the corner (10, 10): nearest contour point is that corner
    fit[4] = [53.0, 54.0]  # on no edge: point-to-point
    errors = metrics.point_to_border_errors(fit, square, edges)
    np.testing.assert_allclose(errors, [3.0, 5.0, 0.0, 0.0, 5.0])


def test_point_to_border_uses_own_contour_only(lfpw_shapes: np.ndarray) -> None:
    gt = lfpw_shapes[0]
    fit = gt.copy()
    fit[36:42] = gt[[17, 18, 19, 20, 21, 21]]  # eye points moved onto the brow contour
    errors = metrics.point_to_border_errors(fit, gt, IBUG68)
    assert np.all(errors[36:42] > 1.0)


def test_point_to_border_without_edges_is_point_to_point(lfpw_shapes: np.ndarray) -> None:
    gt, fit = lfpw_shapes[0], lfpw_shapes[0] + np.random.default_rng(0).normal(0, 2, (68, 2))
    assert metrics.point_to_border(fit, gt, generic_scheme(68)) == pytest.approx(
        metrics.point_to_point(fit, gt)
    )


@settings(max_examples=40, deadline=None)
@given(noise=arrays(np.float64, (68, 2), elements=st.floats(-20, 20)))
def test_point_to_border_never_exceeds_point_to_point(noise: np.ndarray) -> None:
    gt = _lfpw_first_shape()
    fit = gt + noise
    border = metrics.point_to_border_errors(fit, gt, IBUG68)
    assert np.all(border <= metrics.point_errors(fit, gt) + 1e-9)


def test_nme_invariant_to_image_scaling(lfpw_shapes: np.ndarray) -> None:
    gt, fit = lfpw_shapes[0], lfpw_shapes[0] + [4.0, -2.0]
    value = metrics.nme(fit, gt, IBUG68)
    assert value == pytest.approx(metrics.point_to_point(fit, gt) / IBUG68.inter_ocular(gt))
    for k in (0.25, 3.0):
        assert metrics.nme(fit * k + 17.0, gt * k + 17.0, IBUG68) == pytest.approx(value)


def test_nme_rejects_wrong_scheme_and_degenerate_eyes(lfpw_shapes: np.ndarray) -> None:
    with pytest.raises(ValueError, match="68 points"):
        metrics.nme(lfpw_shapes[0][:60], lfpw_shapes[0][:60], IBUG68)
    flat = np.zeros((68, 2))
    with pytest.raises(ValueError, match="eye corners"):
        metrics.nme(flat, flat, IBUG68)


def test_texture_error() -> None:
    assert metrics.texture_error(np.array([1.0, 2.0, 3.0]), np.array([1.0, 0.0, 6.0])) == (
        pytest.approx((0 + 4 + 9) / 3)
    )
    with pytest.raises(ValueError, match="equal in size"):
        metrics.texture_error(np.ones(3), np.ones(4))
    with pytest.raises(ValueError, match="NaN"):
        metrics.texture_error(np.array([np.nan]), np.ones(1))


@settings(max_examples=60, deadline=None)
@given(
    errors=st.lists(st.one_of(st.floats(0, 1), st.just(math.nan)), min_size=1, max_size=50),
    thresholds=st.lists(st.floats(0, 1), min_size=1, max_size=20),
)
def test_ced_is_monotone_fraction(errors: list[float], thresholds: list[float]) -> None:
    ordered = np.sort(thresholds)
    curve = metrics.ced(errors, ordered)
    assert np.all(np.diff(curve) >= 0)
    assert np.all((curve >= 0) & (curve <= 1))
    finite = np.isfinite(errors)
    assert metrics.ced(errors, [1.0])[0] == pytest.approx(finite.mean())
    for t, frac in zip(ordered, curve, strict=True):
        assert frac == pytest.approx(1.0 - metrics.failure_rate(errors, t))


def test_summary_and_failures() -> None:
    errors = np.array([0.02, 0.05, 0.09, 0.2, np.nan])
    summary = metrics.summarise(errors)
    assert summary.n == 5 and summary.n_missing == 1
    assert summary.mean == pytest.approx(np.mean([0.02, 0.05, 0.09, 0.2]))
    assert summary.median == pytest.approx(0.07)
    assert summary.failure_008 == pytest.approx(3 / 5)
    assert summary.failure_010 == pytest.approx(2 / 5)
    np.testing.assert_array_equal(
        metrics.failure_flags(errors, 0.08), [False, False, True, True, True]
    )
    assert set(summary.to_dict()) >= {"mean", "median", "std", "failure_008", "failure_010"}
    with pytest.raises(ValueError, match=">= 0"):
        metrics.summarise([0.1, -0.1])
    with pytest.raises(ValueError, match="no errors"):
        metrics.ced([], [0.1])


@pytest.mark.parametrize(
    ("fit", "message"),
    [
        (np.zeros((68, 3)), r"\(N, 2\)"),
        (np.full((68, 2), np.nan), "NaN"),
        (np.zeros((67, 2)), "differ"),
    ],
)
def test_bad_shapes_raise(lfpw_shapes: np.ndarray, fit: np.ndarray, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        metrics.point_to_point(fit, lfpw_shapes[0])
