"""Saving and loading expression classifiers: round trip, version, pipeline and model checks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from sklearn.decomposition import PCA

from aamcore.expression.classifier_file import (
    FORMAT_VERSION,
    AAMMismatchError,
    ClassifierFileError,
    ExpressionClassifier,
)
from aamcore.expression.face_classifier import fit_face_classifier
from aamcore.expression.lda import FisherMahalanobis
from aamcore.expression.spec import FeatureConfig, PipelineSpec
from aamcore.expression.svm import SVMExpressionClassifier
from tests.aamcore.expression.feature_sets import FeatureSet
from tests.aamcore.expression.synthetic_faces import unit_face

Features = tuple[np.ndarray, np.ndarray]
"""PCA features (n, d) and labels (n,)."""

FINGERPRINT = "aam-test-0123abcd"


@pytest.fixture(scope="module")
def features(five_posers: FeatureSet) -> Features:
    X = PCA(0.95, svd_solver="full").fit_transform(five_posers.features)
    return X, five_posers.labels


def appearance_spec(dim: int) -> PipelineSpec:
    """A pipeline classifying the fitter's ``c`` (dim,) as it is (the thesis's way)."""
    return PipelineSpec(FeatureConfig(blocks=("appearance",)), dim, relative=False)


def _estimator(kind: str, X: np.ndarray, y: np.ndarray):
    if kind == "lda_mahalanobis":
        return FisherMahalanobis(n_components=4).fit(X, y)
    return SVMExpressionClassifier(kind.removeprefix("svm_"), C=8.0, gamma=0.25).fit(X, y)


def _wrapped(kind: str, X: np.ndarray, y: np.ndarray) -> ExpressionClassifier:
    return ExpressionClassifier.from_estimator(_estimator(kind, X, y), FINGERPRINT,
                                               appearance_spec(X.shape[1]))


def _rewrite_header(path: Path, change: dict) -> None:
    with np.load(path, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    header = json.loads(arrays["header"].tobytes())
    for key, value in change.items():
        target = header
        *parents, last = key.split(".")
        for parent in parents:
            target = target[parent]
        target[last] = value
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    np.savez(path, **arrays)


@pytest.mark.parametrize("kind", ["lda_mahalanobis", "svm_ova", "svm_ovo", "svm_dag"])
def test_round_trip_gives_identical_scores(features: Features, kind: str, tmp_path: Path) -> None:
    X, y = features
    estimator = _estimator(kind, X, y)
    classifier = ExpressionClassifier.from_estimator(estimator, FINGERPRINT,
                                                     appearance_spec(X.shape[1]), {"note": "t"})
    path = classifier.save(tmp_path / "expr")
    assert path.suffix == ".npz"

    loaded = ExpressionClassifier.load(path)

    assert loaded.kind == kind
    assert loaded.class_names == tuple(estimator.classes_)
    assert loaded.feature_dim == X.shape[1] == loaded.pipeline.feature_dim
    assert loaded.aam_fingerprint == FINGERPRINT and loaded.info == {"note": "t"}
    np.testing.assert_array_equal(loaded.scores(X), classifier.scores(X))
    np.testing.assert_array_equal(loaded.scores(X), estimator.decision_scores(X))
    assert loaded.predict(X[7:8])[0] == estimator.predict(X[7:8])[0]
    with np.load(path, allow_pickle=False) as archive:  # no object arrays inside
        assert all(archive[name].dtype != object for name in archive.files)


@pytest.mark.parametrize("kind", ["lda", "rbf_svm"])
def test_face_classifier_files_round_trip_with_their_template(
    five_posers: FeatureSet, kind: str, tmp_path: Path
) -> None:
    X, y, g = five_posers.features, five_posers.labels, five_posers.posers
    fitted = fit_face_classifier(X, y, g, {"hog": X.shape[1]}, classifier=kind)
    spec = PipelineSpec(FeatureConfig(blocks=("hog",)), 42, template=unit_face())
    classifier = ExpressionClassifier.from_face_classifier(fitted, spec, FINGERPRINT, {"n": 1})
    loaded = ExpressionClassifier.load(classifier.save(tmp_path / "c"))
    assert loaded.kind == ("linear" if kind == "lda" else "svm_ova")
    assert loaded.pipeline.features == spec.features and loaded.pipeline.relative
    np.testing.assert_array_equal(loaded.pipeline.template, unit_face())
    np.testing.assert_allclose(loaded.scores(X), classifier.scores(X))
    assert loaded.info["n"] == 1 and loaded.info["classifier_params"]["classifier"] == kind


def test_a_person_independent_network_is_stored_beside_the_relative_model(
    five_posers: FeatureSet, tmp_path: Path
) -> None:
    from aamcore.expression.network import NetworkModel, fit_network

    X, y, g = five_posers.features, five_posers.labels, five_posers.posers
    relative = fit_face_classifier(X, y, g, {"hog": X.shape[1]}, classifier="lda")
    network = fit_network(X, y, {"hog": X.shape[1]}, hidden=8, epochs=5)
    spec = PipelineSpec(FeatureConfig(blocks=("hog",)), 42, template=unit_face())
    classifier = ExpressionClassifier.from_face_classifier(relative, spec, FINGERPRINT,
                                                           absolute=network)
    loaded = ExpressionClassifier.load(classifier.save(tmp_path / "c"))
    assert isinstance(loaded.absolute, NetworkModel)
    np.testing.assert_allclose(loaded.absolute_probabilities(X),
                               classifier.absolute_probabilities(X))


def test_other_format_versions_are_refused(features: Features, tmp_path: Path) -> None:
    X, y = features
    path = _wrapped("svm_dag", X, y).save(tmp_path / "c.npz")
    for version in (1, FORMAT_VERSION + 1):  # 1: the classifiers of raw appearance vectors
        _rewrite_header(path, {"format_version": version})
        message = f"format version {version}, this aamtrack reads version {FORMAT_VERSION}"
        with pytest.raises(ClassifierFileError, match=f"{message}: retrain it"):
            ExpressionClassifier.load(path)


def test_another_feature_version_or_an_inconsistent_pipeline_is_refused(
    features: Features, tmp_path: Path
) -> None:
    X, y = features
    path = _wrapped("lda_mahalanobis", X, y).save(tmp_path / "c.npz")
    _rewrite_header(path, {"pipeline.feature_version": 1})
    with pytest.raises(ClassifierFileError, match="face features of version 1.*retrain"):
        ExpressionClassifier.load(path)
    path = _wrapped("lda_mahalanobis", X, y).save(tmp_path / "c.npz")
    _rewrite_header(path, {"pipeline.appearance_dim": X.shape[1] + 1})
    with pytest.raises(ClassifierFileError, match="inconsistent.*length"):
        ExpressionClassifier.load(path)
    _rewrite_header(path, {"pipeline.features.blocks": ["lbp"]})
    with pytest.raises(ClassifierFileError, match="inconsistent"):
        ExpressionClassifier.load(path)


def test_another_model_or_fits_of_another_model_are_refused(features: Features) -> None:
    X, y = features
    classifier = _wrapped("lda_mahalanobis", X, y)
    classifier.check_aam(FINGERPRINT)
    with pytest.raises(AAMMismatchError, match="aam-test-0123abcd.*aam-other.*retrain it"):
        classifier.check_aam("aam-other")
    classifier.check_fit("ibug68", 68, X.shape[1])
    with pytest.raises(AAMMismatchError, match="not on imm58 fits with 58 landmarks"):
        classifier.check_fit("imm58", 58, X.shape[1])
    with pytest.raises(AAMMismatchError, match=f"{X.shape[1]} appearance parameters, this fit "
                       "has 88"):
        classifier.check_fit("ibug68", 68, 88)


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
    path = _wrapped("svm_ova", X, y).save(tmp_path / "c.npz")
    with np.load(path, allow_pickle=False) as archive:
        arrays = {n: archive[n] for n in archive.files if n != "intercepts"}
    np.savez(path, **arrays)
    with pytest.raises(ClassifierFileError, match="inconsistent"):
        ExpressionClassifier.load(path)


def test_bad_vectors_and_unfitted_estimators_are_refused(features: Features) -> None:
    X, y = features
    classifier = _wrapped("svm_ovo", X, y)
    with pytest.raises(ValueError, match=rf"\(n, {X.shape[1]}\)"):
        classifier.scores(X[:, :-1])
    with pytest.raises(ValueError, match="not fitted"):
        ExpressionClassifier.from_estimator(FisherMahalanobis(), FINGERPRINT, appearance_spec(3))
    with pytest.raises(ValueError, match="pipeline makes vectors of length 3"):
        ExpressionClassifier.from_estimator(_estimator("svm_ova", X, y), FINGERPRINT,
                                            appearance_spec(3))


def test_the_deployed_pipeline_takes_fits_without_an_appearance(classifier_path) -> None:
    # A failed fit of a landmark regressor is published without an appearance: its HOG and
    # shape are classified beside zeros; an appearance of another length is another AAM's.
    classifier = ExpressionClassifier.load(classifier_path)
    spec = classifier.pipeline
    assert "appearance" in spec.features.blocks and len(spec.features.blocks) > 1
    classifier.check_fit("ibug68", 68, 0)
    classifier.check_fit("ibug68", 68, spec.appearance_dim)
    with pytest.raises(AAMMismatchError, match="appearance parameters"):
        classifier.check_fit("ibug68", 68, spec.appearance_dim + 1)
    with pytest.raises(AAMMismatchError, match="not on imm58 fits"):
        classifier.check_fit("imm58", 58, 0)
