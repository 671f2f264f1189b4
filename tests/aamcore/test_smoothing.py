"""aamcore.smoothing: the One Euro filter on synthetic signals with known truth."""

from __future__ import annotations

import numpy as np

from aamcore.pose.rotation import rotation_from_rpy
from aamcore.pose.smoothing import PoseSmoother
from aamcore.smoothing import (
    LandmarkSmoother,
    OneEuroFilter,
    OneEuroSettings,
)

FPS = 30.0


def test_noise_on_a_still_signal_is_cut_and_a_steady_motion_is_followed() -> None:
    rng = np.random.default_rng(1)
    still = OneEuroFilter(OneEuroSettings(min_cutoff=1.0, beta=0.0))
    noisy = 5.0 + rng.normal(0, 1.0, 300)
    out = np.array([still(np.array([x]), k / FPS)[0] for k, x in enumerate(noisy)])
    assert np.std(np.diff(out[30:])) < 0.3 * np.std(np.diff(noisy[30:]))
    moving = OneEuroFilter(OneEuroSettings(min_cutoff=1.0, beta=1.0))
    ramp = np.arange(120) * 2.0  # 60 units a second
    followed = np.array([moving(np.array([x]), k / FPS)[0] for k, x in enumerate(ramp)])
    assert abs(followed[-1] - ramp[-1]) < 2.0 * 2.0  # within two frames of motion


def test_the_first_sample_and_a_sample_after_a_gap_pass_unchanged() -> None:
    f = OneEuroFilter()
    np.testing.assert_array_equal(f(np.array([1.0, 2.0]), 0.0), [1.0, 2.0])
    assert f(np.array([3.0, 4.0]), 1 / FPS)[0] < 3.0
    np.testing.assert_array_equal(f(np.array([9.0, 9.0]), 5.0), [9.0, 9.0])  # a 5 s gap
    np.testing.assert_array_equal(f(np.array([7.0, 7.0]), 4.0), [7.0, 7.0])  # time went back
    f.reset()
    np.testing.assert_array_equal(f(np.array([0.0, 0.0]), 4.1), [0.0, 0.0])


def test_landmark_smoothing_does_not_depend_on_the_face_size() -> None:
    rng = np.random.default_rng(2)
    base = rng.uniform(0, 1, (68, 2))
    noise = rng.normal(0, 0.01, (60, 68, 2))
    results = []
    for size in (100.0, 400.0):
        smoother = LandmarkSmoother()
        out = [smoother.update(size * (base + n), k / FPS, True) for k, n in enumerate(noise)]
        results.append(np.array(out) / size)
    np.testing.assert_allclose(results[0], results[1], atol=1e-9)
    smoother = LandmarkSmoother()
    smoother.update(base, 0.0, True)
    raw = base + 0.5
    np.testing.assert_array_equal(smoother.update(raw, 1 / FPS, False), raw)  # a failed fit


def test_a_smoothed_rotation_stays_a_rotation() -> None:
    rng = np.random.default_rng(3)
    smoother = PoseSmoother()
    for k in range(40):
        R = rotation_from_rpy(*rng.normal(0, 3.0, 3))
        T = np.array([0.0, 0.0, 600.0]) + rng.normal(0, 5.0, 3)
        R_s, T_s = smoother(R, T, k / FPS)
        np.testing.assert_allclose(R_s @ R_s.T, np.eye(3), atol=1e-9)
        assert np.linalg.det(R_s) > 0 and abs(T_s[2] - 600.0) < 20.0
