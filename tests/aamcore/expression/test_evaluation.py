"""Leave-one-poser-out evaluation: no leak of the test poser, results and their summaries."""

from __future__ import annotations

import json
from collections.abc import Callable

import numpy as np
import pytest

from aamcore.expression.benchmark import PixelData
from aamcore.expression.evaluation import (
    ClassifierSpec,
    EvaluationResult,
    leave_one_poser_out,
    restrict_classes,
)
from aamcore.expression.features import PixelPCAFeatures
from aamcore.expression.labels import FIVE_CLASSES, SEVEN_CLASSES
from aamcore.expression.lda import FisherMahalanobis


class RecordingPixelPCA:
    """Pixel PCA whose inputs are sample indices; records the posers each fold fits on."""

    def __init__(self, data: PixelData) -> None:
        self.data = data
        self.name = "recording pixel PCA"
        self.fitted_on: list[set[str]] = []
        self.transformed: list[set[str]] = []

    def fit(self, train_inputs: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        index = np.asarray(train_inputs)
        self.fitted_on.append(set(self.data.posers[index]))
        pca = PixelPCAFeatures(0.95).fit(self.data.pixels[index])

        def transform(inputs: np.ndarray) -> np.ndarray:
            self.transformed.append(set(self.data.posers[np.asarray(inputs)]))
            return pca(self.data.pixels[np.asarray(inputs)])

        return transform


class RecordingLDA:
    """LDA+Mahalanobis (3 directions) recording the posers of its training data."""

    def __init__(self) -> None:
        self.trained_on: list[set[str]] = []

    def spec(self) -> ClassifierSpec:
        def fit(X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> FisherMahalanobis:
            self.trained_on.append(set(groups))
            return FisherMahalanobis(n_components=3).fit(X, y)

        return ClassifierSpec("LDA 3", fit)


def test_no_fold_step_sees_the_test_poser(five_posers: PixelData) -> None:
    features = RecordingPixelPCA(five_posers)
    lda = RecordingLDA()
    inputs = np.arange(len(five_posers.labels))
    (result,) = leave_one_poser_out(
        inputs, five_posers.labels, five_posers.posers, features, [lda.spec()], SEVEN_CLASSES
    )
    posers = sorted(set(five_posers.posers))
    assert len(features.fitted_on) == len(lda.trained_on) == len(posers)
    for held_out, fitted, trained in zip(posers, features.fitted_on, lda.trained_on, strict=True):
        assert fitted == trained == set(posers) - {held_out}
    # Each fold maps its training inputs, then the held-out poser alone.
    assert features.transformed[1::2] == [{p} for p in posers]
    assert result.features == "recording pixel PCA"
    assert set(result.fold_params) == set(posers)
    assert all(p["n_components"] == 3 and p["n_features"] > 0 for p in result.fold_params.values())


def test_result_summaries_are_consistent() -> None:
    y_true = np.array(["NE", "NE", "HA", "HA", "SU", "SU", "SU", "FE"])
    y_pred = np.array(["NE", "HA", "HA", "HA", "SU", "FE", "SU", "NE"])
    result = EvaluationResult(
        "x", "f", ("NE", "HA", "SU", "FE", "DI"), y_true, y_pred, np.array(["A"] * 8)
    )
    counts = result.confusion()
    assert counts[0].tolist() == [1, 1, 0, 0, 0] and counts[2].tolist() == [0, 0, 2, 1, 0]
    percent = result.confusion_percent()
    np.testing.assert_allclose(percent[:4].sum(axis=1), 100.0)
    np.testing.assert_array_equal(percent[4], 0.0)  # no disgust sample
    assert result.overall_rate == pytest.approx(5 / 8)
    np.testing.assert_allclose(result.per_class_rates(), [0.5, 1.0, 2 / 3, 0.0, 0.0])
    summary = json.loads(json.dumps(result.to_dict()))
    assert summary["per_class_rates"]["SU"] == pytest.approx(2 / 3)


def test_given_feature_matrix_and_five_classes(five_posers: PixelData) -> None:
    keep = restrict_classes(five_posers.labels, FIVE_CLASSES)
    assert set(five_posers.labels[keep]) == set(FIVE_CLASSES)
    X = PixelPCAFeatures(0.9).fit(five_posers.pixels)(five_posers.pixels)  # not a fair protocol,
    lda = RecordingLDA()  # only the plumbing of a given feature matrix is under test here
    (result,) = leave_one_poser_out(
        X[keep],
        five_posers.labels[keep],
        five_posers.posers[keep],
        None,
        [lda.spec()],
        FIVE_CLASSES,
    )
    assert result.features == "given features"
    assert result.confusion().shape == (5, 5)
    assert result.confusion().sum() == keep.sum()


def test_bad_inputs_are_refused(five_posers: PixelData) -> None:
    X = five_posers.pixels[:, :10]
    lda = RecordingLDA()
    with pytest.raises(ValueError, match="differ in length"):
        leave_one_poser_out(X, five_posers.labels[:-1], five_posers.posers, None, [lda.spec()])
    with pytest.raises(ValueError, match="not among the classes"):
        leave_one_poser_out(
            X, five_posers.labels, five_posers.posers, None, [lda.spec()], FIVE_CLASSES
        )
    with pytest.raises(ValueError, match="2 posers"):
        leave_one_poser_out(X, five_posers.labels, np.full(len(X), "KA"), None, [lda.spec()])
