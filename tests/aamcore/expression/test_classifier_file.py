"""Saving and loading expression classifiers: round trip, version and AAM checks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from sklearn.decomposition import PCA

from aamcore.expression.benchmark import PixelData
from aamcore.expression.classifier_file import (
    FORMAT_VERSION,
    AAMMismatchError,
    ClassifierFileError,
    ExpressionClassifier,
)
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.svm import SVMExpressionClassifier

Features = tuple[np.ndarray, np.ndarray]
"""PCA features (n, d) and labels (n,)."""

FINGERPRINT = "aam-test-0123abcd"


@pytest.fixture(scope="module")
def features(five_posers: PixelData) -> Features:
    X = PCA(0.95, svd_solver="full").fit_transform(five_posers.pixels)
    return X, five_posers.labels


def _estimator(kind: str, X: np.ndarray, y: np.ndarray):
    if kind == "lda_mahalanobis":
        return FisherMahalanobis(n_components=4).fit(X, y)
    return SVMExpressionClassifier(kind.removeprefix("svm_"), C=8.0, gamma=0.25).fit(X, y)


@pytest.mark.parametrize("kind", ["lda_mahalanobis", "svm_ova", "svm_ovo", "svm_dag"])
def test_round_trip_gives_identical_scores(features: Features, kind: str, tmp_path: Path) -> None:
    X, y = features
    estimator = _estimator(kind, X, y)
    classifier = ExpressionClassifier.from_estimator(estimator, FINGERPRINT, {"note": "test"})
    path = classifier.save(tmp_path / "expr")
    assert path.suffix == ".npz"

    loaded = ExpressionClassifier.load(path)

    assert loaded.kind == kind
    assert loaded.class_names == tuple(estimator.classes_)
    assert loaded.feature_dim == X.shape[1]
    assert loaded.aam_fingerprint == FINGERPRINT and loaded.info == {"note": "test"}
    np.testing.assert_array_equal(loaded.scores(X), classifier.scores(X))
    np.testing.assert_array_equal(loaded.scores(X), estimator.decision_scores(X))
    label, scores = loaded.classify(X[7])
    assert label == estimator.predict(X[7:8])[0]
    np.testing.assert_array_equal(scores, estimator.decision_scores(X[7:8])[0])
    with np.load(path, allow_pickle=False) as archive:  # no object arrays inside
        assert all(archive[name].dtype != object for name in archive.files)


def test_other_format_version_is_refused(features: Features, tmp_path: Path) -> None:
    X, y = features
    path = ExpressionClassifier.from_estimator(_estimator("svm_dag", X, y), FINGERPRINT).save(
        tmp_path / "c.npz"
    )
    with np.load(path, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    header = json.loads(arrays["header"].tobytes()) | {"format_version": FORMAT_VERSION + 1}
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    np.savez(path, **arrays)
    message = f"format version {FORMAT_VERSION + 1}, this aamtrack reads version {FORMAT_VERSION}"
    with pytest.raises(ClassifierFileError, match=message):
        ExpressionClassifier.load(path)


def test_other_aam_is_refused(features: Features) -> None:
    X, y = features
    classifier = ExpressionClassifier.from_estimator(
        _estimator("lda_mahalanobis", X, y), FINGERPRINT
    )
    classifier.check_aam(FINGERPRINT)
    with pytest.raises(AAMMismatchError, match="aam-test-0123abcd.*aam-other"):
        classifier.check_aam("aam-other")


def test_broken_files_are_refused(features: Features, tmp_path: Path) -> None:
    X, y = features
    with pytest.raises(ClassifierFileError, match="not found"):
        ExpressionClassifier.load(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_bytes(b"junk")
    with pytest.raises(ClassifierFileError, match="not a readable"):
        ExpressionClassifier.load(tmp_path / "junk.npz")
    np.savez(tmp_path / "plain.npz", a=np.zeros(3))
    with pytest.raises(ClassifierFileError, match="no header"):
        ExpressionClassifier.load(tmp_path / "plain.npz")
    path = ExpressionClassifier.from_estimator(_estimator("svm_ova", X, y), FINGERPRINT).save(
        tmp_path / "c.npz"
    )
    with np.load(path, allow_pickle=False) as archive:
        arrays = {n: archive[n] for n in archive.files if n != "intercepts"}
    np.savez(path, **arrays)
    with pytest.raises(ClassifierFileError, match="inconsistent"):
        ExpressionClassifier.load(path)


def test_classify_refuses_bad_vectors(features: Features) -> None:
    X, y = features
    classifier = ExpressionClassifier.from_estimator(_estimator("svm_ovo", X, y), FINGERPRINT)
    with pytest.raises(ValueError, match=rf"shape \({X.shape[1]},\)"):
        classifier.classify(X[0, :-1])
    bad = X[0].copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        classifier.classify(bad)
    with pytest.raises(ValueError, match="not fitted"):
        ExpressionClassifier.from_estimator(FisherMahalanobis(), FINGERPRINT)
