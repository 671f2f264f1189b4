"""aamcore.expression.reference: the running median and the posers' references."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.reference import NeutralReference, median_of, poser_references


def test_neutral_reference_is_a_running_median_with_window_and_stride() -> None:
    ref = NeutralReference(window=3, stride=2, min_count=2)
    with pytest.raises(ValueError, match="unknown"):
        ref.reference()
    kept = [ref.update(np.array([float(v), -float(v)])) for v in range(9)]
    assert kept == [True, False] * 4 + [True]
    assert ref.count == 3 and ref.ready
    np.testing.assert_allclose(ref.reference(), [6.0, -6.0])  # median of 4, 6, 8
    with pytest.raises(ValueError, match="length"):
        ref.update(np.zeros(3))
    with pytest.raises(ValueError, match="non-finite"):
        ref.update(np.array([np.nan, 0.0]))
    ref.reset()
    assert ref.count == 0 and not ref.ready
    assert ref.to_json() == {"window": 3, "stride": 2, "min_count": 2}


@pytest.mark.parametrize("settings", [{"window": 0}, {"stride": 0}, {"window": 3,
                                                                     "min_count": 4}])
def test_bad_settings_are_refused(settings: dict[str, int]) -> None:
    with pytest.raises(ValueError):
        NeutralReference(**settings)


def test_poser_references_use_only_the_posers_usable_faces() -> None:
    X = np.array([[1.0], [3.0], [100.0], [10.0], [20.0], [30.0]])
    posers = np.array(["A", "A", "A", "B", "B", "B"])
    usable = np.array([True, True, False, True, True, True])
    R = poser_references(X, posers, usable)
    np.testing.assert_allclose(R[:, 0], [2.0, 2.0, 2.0, 20.0, 20.0, 20.0])
    assert median_of(X[3:]).tolist() == [20.0]
    causal = poser_references(X, posers, usable, causal_order=np.array([1, 0, 2, 0, 1, 2]))
    np.testing.assert_allclose(causal[:, 0], [2.0, 3.0, 0.0, 10.0, 15.0, 20.0])
    nobody = poser_references(X, posers, np.zeros(6, bool))
    assert np.all(nobody == 0)
