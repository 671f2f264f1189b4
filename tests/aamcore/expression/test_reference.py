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
    assert ref.to_json() == {"window": 3, "stride": 2, "min_count": 2, "min_neutral": 0.0}


def test_a_long_smile_does_not_become_the_neutral_reference() -> None:
    ref = NeutralReference(window=10, stride=2, min_count=2, min_neutral=0.5)
    neutral, smile = np.zeros(2), np.array([5.0, 5.0])
    offered = [(neutral, 0.9)] * 4 + [(smile, 0.1)] * 40 + [(smile + 0.1, 0.6)] * 2
    kept = [ref.update(v, p) for v, p in offered]
    assert sum(kept) == 3 and not any(kept[4:44])  # one in two of the neutral-looking faces
    np.testing.assert_allclose(ref.reference(), [0.0, 0.0])  # median of 0, 0, 5.1


@pytest.mark.parametrize("settings", [{"window": 0}, {"stride": 0}, {"window": 3,
                                                                     "min_count": 4},
                                      {"min_neutral": 1.5}])
def test_bad_settings_are_refused(settings: dict[str, float]) -> None:
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
