"""Box-to-shape mapping learned from real IMM detections, and the Monte Carlo starts."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from aamcore.detection import mapping as init
from aamcore.detection.boxes import detect_all, landmark_box, match_detection
from aamcore.detection.haar import HaarFaceDetector
from aamcore.evaluation.fits import THESIS_OFFSETS, cog_start
from aamcore.evaluation.metrics import nme
from aamcore.io import AnnotatedSet
from aamcore.model.procrustes import generalised_procrustes
from aamcore.model.similarity import Similarity

HELD_OUT = {"10", "11", "12"}


@pytest.fixture(scope="module")
def split(imm_set: AnnotatedSet) -> tuple[np.ndarray, np.ndarray]:
    subjects = np.array([s.subject for s in imm_set.samples])
    test = np.isin(subjects, sorted(HELD_OUT))
    return np.flatnonzero(~test), np.flatnonzero(test)


@pytest.fixture(scope="module")
def reference(imm_set: AnnotatedSet, split: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    shapes = np.stack([imm_set.samples[i].points for i in split[0]])
    return generalised_procrustes(shapes)[1]


@pytest.fixture(scope="module")
def mapping(
    imm_set: AnnotatedSet,
    imm_detections: list[np.ndarray],
    split: tuple[np.ndarray, np.ndarray],
    reference: np.ndarray,
) -> init.BoxToShapeMapping:
    train = split[0]
    return init.fit_box_to_shape(
        reference,
        [imm_set.samples[i].points for i in train],
        [imm_detections[i] for i in train],
    )


def _held_out_nme(
    imm_set: AnnotatedSet,
    imm_detections: list[np.ndarray],
    test: np.ndarray,
    place: object,
) -> np.ndarray:
    errors = []
    for i in test:
        sample = imm_set.samples[i]
        k = match_detection(imm_detections[i], sample.points)
        assert k is not None
        errors.append(nme(place(imm_detections[i][k]), sample.points, imm_set.scheme))  # type: ignore[operator]
    return np.array(errors)


def test_learned_mapping_places_held_out_starts(
    imm_set: AnnotatedSet,
    imm_detections: list[np.ndarray],
    split: tuple[np.ndarray, np.ndarray],
    mapping: init.BoxToShapeMapping,
    reference: np.ndarray,
) -> None:
    learned = _held_out_nme(imm_set, imm_detections, split[1], mapping.place)
    naive_map = init.BoxMapping.naive(reference)
    naive = _held_out_nme(
        imm_set, imm_detections, split[1], lambda box: naive_map.place(reference, box)
    )
    assert learned.mean() < 0.15
    assert learned.mean() < 0.5 * naive.mean()
    assert mapping.detection_rate > 0.95
    assert mapping.n_train == len(split[0])
    assert 0 < mapping.residual["detector"]["mean_point_error"] < 0.1


def test_landmark_box_fallback_places_held_out_starts(
    imm_set: AnnotatedSet, split: tuple[np.ndarray, np.ndarray], mapping: init.BoxToShapeMapping
) -> None:
    errors = [
        nme(mapping.place(landmark_box(s.points), "landmarks"), s.points, imm_set.scheme)
        for s in (imm_set.samples[i] for i in split[1])
    ]
    assert np.mean(errors) < 0.15


def test_mapping_from_real_detections(
    imm_set: AnnotatedSet, reference: np.ndarray, mapping: init.BoxToShapeMapping
) -> None:
    samples = imm_set.samples[:20:4]
    detections = detect_all(samples, HaarFaceDetector())
    learned = init.fit_box_to_shape(reference, [s.points for s in samples], detections)
    assert learned.n_train == 5 and learned.detection_rate == 1.0
    assert learned.detector.a == pytest.approx(mapping.detector.a, rel=0.15)


def test_fit_recovers_known_coefficients(reference: np.ndarray) -> None:
    rng = np.random.default_rng(3)
    truth = init.BoxMapping(a=2.5, b=0.03, c=0.11, rotation=0.05, with_rotation=True)
    widths = rng.uniform(80, 300, 30)
    boxes = np.column_stack(
        [rng.uniform(0, 400, (30, 2)), widths, widths * rng.uniform(0.9, 1.2, 30)]
    )
    shapes = np.stack([truth.place(reference, box) for box in boxes])
    fitted = init.BoxMapping.fit(reference, boxes, shapes, fit_rotation=True)
    for name in ("a", "b", "c", "rotation"):
        assert getattr(fitted, name) == pytest.approx(getattr(truth, name), abs=1e-9)
    assert fitted.residuals(reference, boxes, shapes)["mean_point_error"] < 1e-9
    no_rotation = init.BoxMapping.fit(reference, boxes, shapes)
    assert no_rotation.rotation == 0.0
    assert no_rotation.a == pytest.approx(truth.a * math.cos(truth.rotation), rel=1e-9)


def test_similarity_onto_recovers_transform(reference: np.ndarray) -> None:
    target = Similarity.from_scale_angle(180.0, -0.2, (310.0, 255.0)).apply(reference)
    sim = init.similarity_onto(reference, target, with_rotation=True)
    assert (sim.scale, sim.angle, sim.tx, sim.ty) == pytest.approx((180.0, -0.2, 310.0, 255.0))
    upright = init.similarity_onto(reference, target)
    assert upright.angle == 0.0 and (upright.tx, upright.ty) == pytest.approx((310.0, 255.0))
    assert upright.scale == pytest.approx(180.0 * math.cos(0.2))


def test_match_detection_prefers_box_over_face(
    imm_set: AnnotatedSet, imm_detections: list[np.ndarray]
) -> None:
    points = imm_set.samples[0].points
    face = imm_detections[0][0]
    gt = landmark_box(points)
    far = np.array([0.0, 0.0, 50.0, 50.0])
    # Centre inside the landmark box but much smaller than the face.
    tiny = np.array([gt[0] + gt[2] / 2 - 5, gt[1] + gt[3] / 2 - 5, 10.0, 10.0])
    assert match_detection(np.stack([far, tiny, face]), points) == 2
    assert match_detection(far[None], points) is None
    assert match_detection(np.zeros((0, 4)), points) is None


def test_json_round_trip(mapping: init.BoxToShapeMapping) -> None:
    text = json.dumps(mapping.to_json())
    back = init.BoxToShapeMapping.from_json(json.loads(text))
    box = np.array([250.0, 180.0, 210.0, 210.0])
    np.testing.assert_allclose(back.place(box), mapping.place(box))
    np.testing.assert_allclose(back.place(box, "landmarks"), mapping.place(box, "landmarks"))
    assert back.residual == mapping.residual and back.detection_rate == mapping.detection_rate
    bare = mapping.to_json(include_reference=False)
    assert "reference" not in bare
    with pytest.raises(ValueError, match="reference"):
        init.BoxToShapeMapping.from_json(bare)
    again = init.BoxToShapeMapping.from_json(bare, reference=mapping.reference)
    np.testing.assert_allclose(again.place(box), mapping.place(box))
    with pytest.raises(ValueError, match="detector"):
        init.BoxToShapeMapping.from_json({"reference": mapping.reference.tolist()})


def test_cog_start_is_centred_on_ground_truth(
    imm_set: AnnotatedSet, imm_detections: list[np.ndarray], mapping: init.BoxToShapeMapping
) -> None:
    points = imm_set.samples[5].points
    for box in (None, imm_detections[5][0]):
        start = cog_start(mapping, points, box)
        np.testing.assert_allclose(start.mean(axis=0), points.mean(axis=0), atol=1e-9)
        assert nme(start, points, imm_set.scheme) < 0.15


def test_thesis_offsets() -> None:
    assert 0 in THESIS_OFFSETS and -50 in THESIS_OFFSETS and 50 in THESIS_OFFSETS


def test_bad_inputs_raise(reference: np.ndarray, mapping: init.BoxToShapeMapping) -> None:
    with pytest.raises(ValueError, match="centred"):
        init.BoxToShapeMapping(reference + 5.0, mapping.detector, mapping.landmarks)
    with pytest.raises(ValueError, match="positive"):
        mapping.place(np.array([0.0, 0.0, 0.0, 10.0]))
    with pytest.raises(ValueError, match="4 finite"):
        mapping.place(np.array([0.0, 0.0, 10.0]))
    with pytest.raises(ValueError, match="box source"):
        mapping.place(np.array([0.0, 0.0, 10.0, 10.0]), "haar")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="no detection matched"):
        init.fit_box_to_shape(reference, [reference * 100 + 300], [np.zeros((0, 4))])
    with pytest.raises(ValueError, match="detection lists"):
        init.fit_box_to_shape(reference, [reference], [])
