"""aamcore.expression.training: JAFFE fitted as the stack fits it, the deployed classifier,
trained and cached per fitting model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.expression import ExpressionClassifier
from aamcore.expression import training as models
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.spec import STREAM_REFERENCE
from aamcore.expression.training import JaffeFaces, shape_template, stack_observations
from aamcore.expression.variants import DEPLOYED
from aamcore.fitting.model import FittingModel


def test_every_jaffe_face_is_observed_as_the_stack_fits_it(jaffe: JaffeFaces) -> None:
    assert len(jaffe.observations) == len(jaffe.labels) == len(jaffe.posers) == 213
    assert not jaffe.no_face.any()  # Haar finds every JAFFE face
    obs = jaffe.observations[0]
    assert obs.landmarks.shape == (68, 2) and obs.image.shape == (256, 256)
    np.testing.assert_array_equal(obs.landmarks, obs.landmarks.astype(np.float32))
    assert set(jaffe.labels) == set(SEVEN_CLASSES) and len(set(jaffe.posers)) == 10
    assert jaffe.names[0].endswith(".tiff")


def test_an_image_without_a_face_is_observed_as_no_face(model_path: Path) -> None:
    (obs,) = stack_observations(FittingModel.load(model_path), [np.full((240, 320), 90,
                                                                        np.uint8)])
    assert obs.landmarks.shape == (0, 2) and obs.fit_failed and obs.fit_reason == "no face"


def test_the_cached_classifier_is_the_deployed_pipeline_of_the_model(
    model_path: Path, classifier_path: Path
) -> None:
    classifier = ExpressionClassifier.load(classifier_path)
    spec = classifier.pipeline
    assert classifier.kind == "linear" and spec.features == DEPLOYED.config()
    assert spec.relative and spec.reference == STREAM_REFERENCE and spec.template is not None
    assert spec.appearance_dim == FittingModel.load(model_path).aam.n_appearance
    assert classifier.feature_dim == 51 * 36 + 136
    assert classifier.aam_fingerprint == models.model_fingerprint(model_path)
    assert set(classifier.class_names) == set(SEVEN_CLASSES)
    assert classifier.info["samples"] >= 200  # of 213: failed fits are trained on too
    assert classifier.info["training_version"] == models.TRAINING_VERSION
    assert classifier_path.name.endswith(f"-v{models.TRAINING_VERSION}.npz")


def test_train_deployed_learns_the_training_faces(jaffe: JaffeFaces, model_path: Path) -> None:
    trained = models.train_deployed(jaffe, FittingModel.load(model_path).aam.n_appearance)
    fitted, spec, n = trained.fitted, trained.spec, trained.n_samples
    assert n == 213 and spec.feature_dim == 1972
    np.testing.assert_allclose(spec.template, shape_template(jaffe.observations,
                                                             np.ones(213, bool)))
    with pytest.raises(ValueError, match="no usable face"):
        shape_template(jaffe.observations, np.zeros(213, bool))
    assert set(fitted.classes) == set(SEVEN_CLASSES)
    # The person-independent model and both temperatures, fitted on held-out posers: the
    # scores' softmax is neither a hard vote nor uniform.
    assert trained.absolute is not None and trained.absolute.classes == fitted.classes
    for t in (trained.temperature, trained.absolute_temperature):
        assert 0.01 < t < 100.0
    held_out = models.train_deployed(jaffe, FittingModel.load(model_path).aam.n_appearance,
                                     train=jaffe.posers != "KA")
    assert held_out.n_samples < n


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
