"""aamcore.expression.calibration: softmax, the fitted temperature, held-out scores, reliability."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.calibration import (
    fit_temperature,
    held_out_scores,
    reliability,
    softmax,
)


def test_softmax_rows_sum_to_one_and_keep_the_order() -> None:
    scores = np.array([[-15.7, 28.9, 0.0], [1.0, 1.0, 1.0]])
    p = softmax(scores, 2.0)
    assert np.allclose(p.sum(axis=1), 1.0) and np.all(p >= 0)
    assert np.argmax(p[0]) == 1 and np.allclose(p[1], 1 / 3)
    assert softmax(scores, 1000.0)[0].max() < 0.4  # a hot softmax is nearly uniform


def test_the_fitted_temperature_is_the_one_the_labels_were_drawn_with() -> None:
    rng = np.random.default_rng(0)
    scores = rng.normal(0.0, 4.0, (4000, 5))
    for true_t in (0.5, 3.0):
        p = softmax(scores, true_t)
        truth = np.array([rng.choice(5, p=row) for row in p])
        assert fit_temperature(scores, truth) == pytest.approx(true_t, rel=0.15)
    with pytest.raises(ValueError):
        fit_temperature(scores, np.zeros(3, int))


def test_held_out_scores_come_from_a_model_that_did_not_see_the_group() -> None:
    X = np.arange(12.0)[:, None]
    y = np.array(["a", "b"] * 6)
    groups = np.repeat(["p", "q", "r"], 4)
    seen: list[set[str]] = []

    def fit(Xt: np.ndarray, yt: np.ndarray, gt: np.ndarray):
        seen.append(set(gt))
        return lambda rows: np.hstack([rows, -rows])

    out = held_out_scores(fit, X, y, groups)
    assert out.shape == (12, 2) and np.allclose(out[:, 0], X[:, 0])
    assert seen == [{"q", "r"}, {"p", "r"}, {"p", "q"}]
    seen.clear()
    held_out_scores(fit, X, y, groups, folds=2)  # p and r together, q alone
    assert seen == [{"q"}, {"p", "r"}]


def test_reliability_bins_count_every_face_once() -> None:
    confidence = np.array([0.3, 0.55, 0.65, 0.95, 1.0])
    correct = np.array([False, True, False, True, True])
    rows = reliability(confidence, correct)
    assert sum(n for _, n, _, _ in rows) == 5
    top = rows[-1]
    assert top[0] == "0.9-1.0" and top[1] == 2 and top[3] == 1.0


def test_class_biases_win_back_a_class_the_scores_undervalue() -> None:
    from aamcore.expression.calibration import class_biases, decision_score

    rng = np.random.default_rng(1)
    truth = rng.integers(0, 3, 600)
    log_p = rng.normal(0, 1, (600, 3)) + 2.0 * np.eye(3)[truth]
    log_p[:, 0] -= 2.5  # the first class (neutral, say) is rarely the top score
    before = decision_score(log_p.argmax(axis=1), truth, 3)
    offsets = class_biases(log_p, truth)
    after = (log_p + offsets).argmax(axis=1)
    assert decision_score(after, truth, 3) > before + 0.1
    assert np.mean(after[truth == 0] == 0) > 0.6 > np.mean(log_p.argmax(axis=1)[truth == 0] == 0)
    assert offsets[0] > offsets[1:].max() and abs(offsets.sum()) < 1e-9
