"""aamcore.expression.training: the classifier of the AAM in use, trained on JAFFE and cached."""

from __future__ import annotations

from pathlib import Path

from aamcore.expression import ExpressionClassifier
from aamcore.expression import training as models
from aamcore.model.file import load_model


def test_the_cached_classifier_belongs_to_the_model(
    model_path: Path, classifier_path: Path
) -> None:
    classifier = ExpressionClassifier.load(classifier_path)
    assert classifier.feature_dim == load_model(model_path).n_appearance
    assert classifier.aam_fingerprint == models.model_fingerprint(model_path)
    assert set(classifier.class_names) == {"NE", "HA", "SA", "SU", "AN", "FE", "DI"}
    assert classifier.info["samples"] >= 150  # of 213 JAFFE images


def test_a_cached_classifier_is_reused(model_path: Path, classifier_path: Path) -> None:
    before = classifier_path.stat().st_mtime_ns
    assert models.classifier_path(model_path) == classifier_path
    assert classifier_path.stat().st_mtime_ns == before


def test_fingerprints_tell_models_apart(tmp_path: Path, model_path: Path) -> None:
    copy = tmp_path / "copy.npz"
    copy.write_bytes(model_path.read_bytes())
    other = tmp_path / "other.npz"
    other.write_bytes(model_path.read_bytes() + b"\0")
    fingerprint = models.model_fingerprint(model_path)
    assert models.model_fingerprint(copy) == fingerprint != models.model_fingerprint(other)
