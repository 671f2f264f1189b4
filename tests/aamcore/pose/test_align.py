"""Least-squares similarity alignment."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.pose.align import align_points
from aamcore.pose.rotation import rotation_from_rpy


@pytest.mark.parametrize("dim", [2, 3])
def test_recovers_a_known_similarity(dim: int) -> None:
    rng = np.random.default_rng(dim)
    src = rng.normal(size=(20, dim))
    R = rotation_from_rpy(20, -10, 35) if dim == 3 else np.array(
        [[np.cos(0.7), -np.sin(0.7)], [np.sin(0.7), np.cos(0.7)]])
    dst = 2.5 * src @ R.T + np.arange(1.0, dim + 1)
    sim = align_points(src, dst)
    assert sim.scale == pytest.approx(2.5)
    assert np.allclose(sim.R, R) and np.allclose(sim.apply(src), dst)
    rigid = align_points(src, src @ R.T, with_scale=False)
    assert rigid.scale == 1.0 and np.allclose(rigid.R, R)


def test_never_returns_a_reflection() -> None:
    src = np.random.default_rng(0).normal(size=(10, 3))
    mirrored = src * np.array([-1.0, 1.0, 1.0])
    assert np.linalg.det(align_points(src, mirrored).R) == pytest.approx(1.0)


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="equal shape"):
        align_points(np.zeros((5, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="all equal"):
        align_points(np.ones((5, 2)), np.zeros((5, 2)))
