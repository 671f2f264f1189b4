"""aamcore.expression.training: the deployed classifier learned from the training people of the
three expression sets as the stack fits them, cached per fitting model; the thesis's on JAFFE."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.expression import ExpressionClassifier
from aamcore.expression import training as models
from aamcore.expression.faces import LabelledFaces
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.spec import STREAM_REFERENCE
from aamcore.fitting.model import FittingModel
from aamcore.io.expression_sets import load_expression_set
from tests.conftest import CLASSIFIER_LIMIT


def test_the_training_faces_are_the_training_people_only(data_dir: Path) -> None:
    taiwan = load_expression_set("taiwan_expressions", data_dir / "taiwan_expressions")
    chosen = models.training_selection(taiwan)
    assert not (chosen & taiwan.held_out()).any() and (chosen | taiwan.held_out()).all()
    few = models.training_selection(taiwan, limit=3)
    labels = taiwan.labels()
    assert not (few & taiwan.held_out()).any()
    assert {name: int(np.sum(few & (labels == name))) for name in SEVEN_CLASSES} == dict.fromkeys(
        SEVEN_CLASSES, 3)
    jaffe = load_expression_set("jaffe", data_dir / "jaffe")
    assert models.training_selection(jaffe, limit=3).all()  # JAFFE has no held-out people


def test_the_cached_classifier_is_the_deployed_pipeline_of_the_model(
    model_path: Path, classifier_path: Path
) -> None:
    classifier = ExpressionClassifier.load(classifier_path)
    spec = classifier.pipeline
    assert classifier.kind == "linear" and spec.features == models.FEATURES
    assert spec.relative and spec.reference == STREAM_REFERENCE and spec.template is not None
    assert classifier.absolute is not None
    assert classifier.absolute_weight == models.RECIPE.absolute_weight
    assert spec.appearance_dim == FittingModel.load(model_path).aam.n_appearance
    assert classifier.feature_dim == 51 * 36 + 136 + spec.appearance_dim
    assert info_of(classifier)["classifier"] == models.RECIPE.learner
    assert classifier.aam_fingerprint == models.model_fingerprint(model_path)
    assert set(classifier.class_names) == set(SEVEN_CLASSES)
    info = classifier.info
    assert info["limit"] == CLASSIFIER_LIMIT and info["training_version"] == models.TRAINING_VERSION
    # JAFFE whole and at most CLASSIFIER_LIMIT faces of each class of the two other sets,
    # failed fits learned from too; the relative model from people with several faces.
    assert 200 < info["samples"] <= 213 + 2 * 7 * CLASSIFIER_LIMIT
    assert 0 < info["samples_relative"] <= info["samples_absolute"] == info["samples"]


def info_of(classifier: ExpressionClassifier) -> dict:
    """The person-independent model's parameters as the file records them."""
    return classifier.info["absolute_params"]


def test_train_deployed_learns_both_models_of_the_training_faces(jaffe: LabelledFaces,
                                                                 model_path: Path) -> None:
    n_appearance = FittingModel.load(model_path).aam.n_appearance
    trained = models.train_deployed(jaffe, n_appearance)
    learned, spec = trained.learned, trained.spec
    assert trained.n_samples == 213 and spec.feature_dim == 1972 + n_appearance and spec.relative
    assert learned.relative is not None and learned.relative.classes == learned.absolute.classes
    assert set(learned.absolute.classes) == set(SEVEN_CLASSES)
    # Temperatures fitted on held-out posers: the softmax is neither a hard vote nor uniform.
    for t in (learned.temperature, learned.absolute_temperature, learned.fused_temperature):
        assert 0.01 < t < 100.0
    held_out = models.train_deployed(jaffe, n_appearance, train=jaffe.posers != "KA")
    assert held_out.n_samples < trained.n_samples
    with pytest.raises(ValueError, match="no face passes"):
        models.train_deployed(jaffe, n_appearance, train=np.zeros(213, bool))


def test_a_class_without_faces_is_said_not_a_crash(jaffe: LabelledFaces, model_path: Path
                                                   ) -> None:
    said: list[str] = []
    trained = models.train_deployed(jaffe, FittingModel.load(model_path).aam.n_appearance,
                                    train=jaffe.labels != "FE", say=said.append)
    assert "FE" not in trained.learned.absolute.classes
    assert any("no classifiable face of FE" in line for line in said)
    classifier = trained.classifier("x")
    assert len(classifier.class_names) == 6


def test_a_cached_classifier_is_reused(model_path: Path, classifier_path: Path) -> None:
    before = classifier_path.stat().st_mtime_ns
    assert models.classifier_path(model_path, limit=CLASSIFIER_LIMIT) == classifier_path
    assert classifier_path.stat().st_mtime_ns == before


def test_fingerprints_tell_models_apart(tmp_path: Path, model_path: Path) -> None:
    copy = tmp_path / "copy.npz"
    copy.write_bytes(model_path.read_bytes())
    other = tmp_path / "other.npz"
    other.write_bytes(model_path.read_bytes() + b"\0")
    fingerprint = models.model_fingerprint(model_path)
    assert models.model_fingerprint(copy) == fingerprint != models.model_fingerprint(other)
