"""aamcore.expression.pipeline: one stream's gate, reference and classifier, on synthetic faces
and, for the occlusion flags, real ones."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from aamcore.expression.classifier_file import ExpressionClassifier
from aamcore.expression.crop import FaceObservation, aligned_face
from aamcore.expression.face_classifier import LinearModel
from aamcore.expression.pipeline import ExpressionPipeline
from aamcore.expression.spec import FeatureConfig, PipelineSpec
from tests.aamcore.expression.synthetic_faces import (
    expression_observation,
    place,
    stream_classifier,
    unit_face,
)


@pytest.fixture(scope="module")
def classifier() -> ExpressionClassifier:
    return stream_classifier()


def test_a_stream_learns_its_reference_then_classifies(classifier: ExpressionClassifier) -> None:
    pipeline = ExpressionPipeline(classifier)
    person = 0.05  # a person the classifier has not seen
    first = pipeline.process(expression_observation("NE", person))
    assert not first.ok and first.reason == "learning the face's reference: 1 of 3 samples"
    assert first.scores is None and first.reference_count == 1
    pipeline.process(expression_observation("HA", person))
    third = pipeline.process(expression_observation("SU", person))
    assert third.ok and third.label == "SU" and third.reference_count == 3 and third.reason == ""
    assert third.scores is not None and third.scores.shape == (3,)
    assert pipeline.process(expression_observation("HA", person)).label == "HA"
    assert pipeline.process(expression_observation("NE", person)).label == "NE"


def test_refused_faces_say_why_and_a_long_loss_forgets_the_reference(
    classifier: ExpressionClassifier,
) -> None:
    pipeline = ExpressionPipeline(classifier, lost_frames_reset=3)
    for kind in ("NE", "HA", "SU"):
        pipeline.process(expression_observation(kind, 0.0))
    face = unit_face()
    face[27:36, 0] += 0.5
    profile = pipeline.process(expression_observation("NE", 0.0,
                                                      place(face, 60.0, 0.0, (160.0, 110.0))))
    assert profile.label is None and profile.reason.startswith("face in profile")
    assert profile.reference_count == 3
    lost = FaceObservation.from_arrays(np.zeros((240, 320), np.uint8), None, None, True,
                                       "no face")
    assert pipeline.process(lost).reason == "no face"
    assert pipeline.process(lost).reference_count == 0  # third frame without a face
    pipeline.process(expression_observation("NE", 0.0))
    pipeline.reset()
    assert pipeline.reference.count == 0
    with pytest.raises(ValueError):
        ExpressionPipeline(classifier, lost_frames_reset=0)


def test_an_appearance_vector_of_another_length_gives_no_expression() -> None:
    spec = PipelineSpec(FeatureConfig(blocks=("shape", "appearance")), appearance_dim=3,
                        relative=False)
    model = LinearModel(np.zeros(139), np.ones(139), np.zeros((2, 139)), np.zeros(2))
    classifier = ExpressionClassifier("linear", ("NE", "HA"), "model", model, spec)
    pipeline = ExpressionPipeline(classifier)
    obs = expression_observation("NE", 0.0)
    assert pipeline.process(obs).label == "NE"  # absolute: no reference to learn
    longer = FaceObservation.from_arrays(obs.image, obs.landmarks, np.zeros(5))
    assert pipeline.process(longer).reason.startswith("wrong feature length: 141")
    unsampled = FaceObservation.from_arrays(obs.image, obs.landmarks, None, fit_failed=True)
    assert pipeline.process(unsampled).label == "NE"  # a failed fit's appearance: zeros
    alone = replace(spec, features=FeatureConfig(blocks=("appearance",)))
    classifier = ExpressionClassifier("linear", ("NE", "HA"), "model", LinearModel(
        np.zeros(3), np.ones(3), np.zeros((2, 3)), np.zeros(2)), alone)
    assert ExpressionPipeline(classifier).process(unsampled).label is None


def test_a_stream_that_opens_on_an_expression_is_read_from_its_first_frame() -> None:
    """The person-independent model labels frames until the reference (the running median of
    every classifiable frame) is ready; then its answer is fused with the relative model's,
    so a stream that opens laughing is not read as neutral once its reference is the laugh."""
    classifier = replace(stream_classifier(min_count=3, absolute=True), absolute_weight=1.0)
    pipeline = ExpressionPipeline(classifier)
    person = 0.05
    opening = [pipeline.process(expression_observation("HA", person)) for _ in range(2)]
    assert all(e.ok and e.basis == "absolute" and e.label == "HA" for e in opening)
    for e in opening:
        assert e.scores is not None and np.isclose(e.scores.sum(), 1.0)
    later = [pipeline.process(expression_observation("HA", person)) for _ in range(4)]
    assert pipeline.reference.count == 6 and all(e.basis == "relative" for e in later)
    assert [e.label for e in later] == ["HA"] * 4
    relative_alone = ExpressionPipeline(replace(classifier, absolute_weight=0.0))
    for _ in range(6):
        last = relative_alone.process(expression_observation("HA", person))
    assert last.label == "NE"  # a laugh as the reference reads as neutral without the fusion
    for kind in ("NE", "SU", "NE", "SU", "NE"):
        pipeline.process(expression_observation(kind, person))
    assert pipeline.process(expression_observation("SU", person)).label == "SU"


def test_the_reference_is_the_neutral_face_not_a_long_smile() -> None:
    """With ``min_neutral``, only the frames the person-independent model calls neutral enter
    the reference: a stream that laughs for long keeps no laugh as its neutral face, and once
    neutral frames came, the relative model alone reads the laugh as a laugh."""
    made = stream_classifier(min_count=3, absolute=True)
    spec = replace(made.pipeline, reference=made.pipeline.reference | {"min_neutral": 0.5})
    pipeline = ExpressionPipeline(replace(made, pipeline=spec, absolute_weight=0.0))
    person = 0.05
    laughing = [pipeline.process(expression_observation("HA", person)) for _ in range(8)]
    assert pipeline.reference.count == 0
    assert all(e.basis == "absolute" and e.label == "HA" for e in laughing)
    for _ in range(3):
        pipeline.process(expression_observation("NE", person))
    assert pipeline.reference.count == 3
    later = pipeline.process(expression_observation("HA", person))
    assert later.basis == "relative" and later.label == "HA"


def test_what_lies_under_the_flagged_landmarks_says_nothing(jaffe, classifier_path) -> None:
    """Real faces, the trained classifier: the mouth painted over with stripes (as a hand's
    fingers would lie) turns the labels when nothing is flagged; with the landmarks whose
    patches reach the paint flagged occluded, the probabilities hardly move (only the crop's
    equalisation sees the paint) and the stream's reference does not learn from the face."""
    loaded = ExpressionClassifier.load(classifier_path)
    quality = replace(loaded.pipeline.quality, max_covered=0.6)  # the whole mouth may be
    # flagged; every face seen whole enters the reference, whatever the model calls neutral
    reference = dict(loaded.pipeline.reference) | {"min_neutral": 0.0}
    deployed = replace(loaded, pipeline=replace(loaded.pipeline, quality=quality,
                                                reference=reference))
    config = deployed.pipeline.features
    moved, entered = {True: 0.0, False: 0.0}, {True: 0, False: 0}
    for obs in jaffe.observations[::40]:
        crop_points = aligned_face(obs.image, obs.landmarks, config.crop_size,
                                   config.eye_distance, config.eye_row)[1]
        (x0, y0), (x1, y1) = obs.landmarks[48:].min(axis=0), obs.landmarks[48:].max(axis=0)
        painted = obs.image.copy()
        rows, cols = np.mgrid[: painted.shape[0], : painted.shape[1]]
        box = (cols >= x0) & (cols <= x1) & (rows >= y0) & (rows <= y1)
        painted[box] = np.where(cols[box] // 4 % 2 == 0, 200, 120)
        (u0, v0), (u1, v1) = crop_points[48:].min(axis=0), crop_points[48:].max(axis=0)
        reach = config.hog_half + 3  # a patch's half side, the warp's and gradient's pixels
        flags = ((crop_points[:, 0] >= u0 - reach) & (crop_points[:, 0] <= u1 + reach)
                 & (crop_points[:, 1] >= v0 - reach) & (crop_points[:, 1] <= v1 + reach))
        flags[:17] = False
        for flagged in (True, False):
            scores = []
            for image in (obs.image, painted):
                pipeline = ExpressionPipeline(deployed)
                seen = pipeline.process(FaceObservation.from_arrays(
                    image, obs.landmarks, obs.appearance, occluded=flags if flagged else None))
                assert seen.scores is not None, seen.reason
                entered[flagged] += pipeline.reference.count
                scores.append(seen.scores)
            moved[flagged] += 0.5 * float(np.abs(scores[0] - scores[1]).sum())
    assert moved[False] > 0.5  # the paint is read where nothing is flagged
    assert moved[True] < 0.2 * moved[False]
    assert entered[True] == 0 < entered[False] == 2 * len(jaffe.observations[::40])
