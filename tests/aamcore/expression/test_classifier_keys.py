"""The expression classifier cache keyed by fitting model, algorithm and feature set, and a
classifier made for other fits refused with one line naming both."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from aamcore.expression import AAMMismatchError, ExpressionClassifier, training
from aamcore.expression.training import TRAINING_VERSION, check_made_for, model_fingerprint
from tests.conftest import CLASSIFIER_LIMIT


def test_the_cache_names_model_algorithm_and_features(model_path: Path,
                                                     classifier_path: Path) -> None:
    fingerprint = model_fingerprint(model_path)
    assert classifier_path.name == (f"expression-{fingerprint}-local-binary-deployed-limit"
                                    f"{CLASSIFIER_LIMIT}-v{TRAINING_VERSION}.npz")
    thesis = classifier_path_of(model_path)
    assert thesis.name == f"expression-{fingerprint}-fixed-jacobian-thesis-v{TRAINING_VERSION}.npz"
    made = ExpressionClassifier.load(thesis)
    assert made.kind == "lda_mahalanobis" and made.pipeline.features.blocks == ("appearance",)
    assert made.info["algorithm"] == "fixed-jacobian" and made.info["features"] == "thesis"
    assert not made.pipeline.relative


def classifier_path_of(model_path: Path) -> Path:
    return training.classifier_path(model_path, "fixed-jacobian", "thesis")


def test_a_classifier_for_other_fits_is_refused_naming_both(model_path: Path,
                                                           classifier_path: Path) -> None:
    made = ExpressionClassifier.load(classifier_path)
    fingerprint = model_fingerprint(model_path)
    check_made_for(made, fingerprint, "local-binary")  # its own fits
    with pytest.raises(AAMMismatchError) as info:
        check_made_for(made, fingerprint, "fixed-jacobian")
    message = str(info.value)
    assert "\n" not in message and f"model {fingerprint} by local-binary" in message
    assert f"those of model {fingerprint} by fixed-jacobian" in message
    other = replace(made, aam_fingerprint="0123456789abcdef")
    with pytest.raises(AAMMismatchError, match="model 0123456789abcdef by local-binary, not"):
        check_made_for(other, fingerprint, "local-binary")
    with pytest.raises(ValueError, match="unknown expression features"):
        training.classifier_path(model_path, "local-binary", "hog-only")
