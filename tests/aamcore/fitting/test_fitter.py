import numpy as np
import pytest

from aamcore.evaluation.metrics import nme
from aamcore.fitting.algorithm.fixed_jacobian import FixedJacobian
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.fitting.tracker import Tracker
from aamcore.fitting.training.update import train_update
from aamcore.fitting.update_matrix import PerturbationScheme
from aamcore.model.similarity import Similarity


def _nme(result, sample, scheme) -> float:
    return nme(result.points, sample.points, scheme)


def predicts(fit, sample, scheme) -> bool:
    """Whether a fit's quality score (its predicted log NME) gives its NME against the truth
    of ``sample`` within a factor 2.5 (measured on the IMM faces: 0.6 to 1.5)."""
    return 1 / 2.5 < np.exp(fit.score) / nme(fit.points, sample.points, scheme) < 2.5


def _true_pose_start(fitter, sample, dx=0.0, dy=0.0):
    _, sim = fitter.aam.shape.fit_points(sample.points)
    return np.zeros(fitter.aam.n_appearance), Similarity(sim.a, sim.b, sim.tx + dx, sim.ty + dy)


@pytest.mark.parametrize(
    "algorithm", ["fixed-jacobian", "multi-resolution", "project-out-ic", "supervised-descent"]
)
def test_fit_from_displaced_start_on_held_out_subjects(imm_fit_model, imm_test, algorithm) -> None:
    fitter = Fitter(imm_fit_model, algorithm)
    scheme = fitter.aam.scheme
    errors, starts = [], []
    for sample in imm_test[::3]:
        c0, t0 = _true_pose_start(fitter, sample, dx=20.0)
        starts.append(nme(fitter.aam.shape_instance(c0, t0), sample.points, scheme))
        result = fitter.fit(sample.load_image(), c0, t0)
        errors.append(_nme(result, sample, scheme))
        assert isinstance(result, AAMFit) and result.residual.shape == (fitter.aam.frame.n_pixels,)
        assert result.iterations >= 1 and len(result.seconds) == result.iterations
    assert np.median(errors) < 0.05
    assert np.mean(errors) < 0.5 * np.mean(starts)


def test_haar_start_fits_held_out_faces(imm_fit_model, imm_test) -> None:
    tracker = Tracker(Fitter(imm_fit_model))
    errors = []
    for sample in imm_test[::4]:
        tracker.reset()
        result = tracker.track(sample.load_image())
        assert result is not None
        errors.append(_nme(result, sample, imm_fit_model.aam.scheme))
    assert np.mean(errors) < 0.05


def test_tracking_reuses_the_last_fit(imm_fit_model, imm_test) -> None:
    tracker = Tracker(Fitter(imm_fit_model))
    image = imm_test[0].load_image()
    first = tracker.track(image)
    assert first is not None and first.ok and tracker.detections == 1
    again = tracker.track(image)
    assert again is not None and tracker.detections == 1
    drift = np.linalg.norm(again.points - first.points, axis=1).mean()
    assert drift < 0.02 * imm_fit_model.aam.scheme.inter_ocular(first.points)


def test_regression_and_jacobian_updates(imm_fit_model, imm_train, imm_test) -> None:
    scheme = PerturbationScheme()
    aam = imm_fit_model.aam
    for method in ("regression", "jacobian"):
        update = train_update(aam, imm_train, method, scheme, max_images=10)
        assert update.R.shape == (aam.n_appearance + 4, aam.frame.n_pixels)
        algorithm = FixedJacobian(aam, update)
        sample = imm_test[1]
        _, sim = aam.shape.fit_points(sample.points)
        sim = Similarity(sim.a, sim.b, sim.tx + 12.0, sim.ty - 8.0)
        c0 = np.zeros(aam.n_appearance)
        image = aam.prepare_image(sample.load_image())
        start = nme(aam.shape_instance(c0, sim), sample.points, aam.scheme)
        result = algorithm.run(image, c0, sim)
        assert nme(result.points, sample.points, aam.scheme) < 0.5 * start
        assert result.errors[-1] <= result.errors[0]


def test_no_face_and_odd_images(imm_fit_model, imm_test) -> None:
    tracker = Tracker(Fitter(imm_fit_model))
    assert tracker.track(np.full((480, 640, 3), 127, np.uint8)) is None
    image = imm_test[2].load_image()
    for variant in (
        image[..., 0],
        np.dstack([image, np.full(image.shape[:2], 255, np.uint8)]),
        image.astype(np.uint16) * 257,
    ):
        tracker.reset()
        result = tracker.track(variant)
        assert result is not None
        assert nme(result.points, imm_test[2].points, imm_fit_model.aam.scheme) < 0.1


def test_bad_starts_give_clear_results(imm_fit_model, imm_test) -> None:
    fitter = Fitter(imm_fit_model)
    image = imm_test[0].load_image()
    with pytest.raises(ValueError, match="box"):
        fitter.fit_box(image, [10, 10, 0, 0])
    with pytest.raises(ValueError, match="NaN"):
        fitter.fit_shape(image, np.full((imm_fit_model.aam.scheme.n_points, 2), np.nan))
    # A box mostly outside the image still gives a result, flagged or not, never a crash.
    result = fitter.fit_box(image, [700, 500, 300, 300])
    assert result.points.shape == (imm_fit_model.aam.scheme.n_points, 2)
    # A far-off start is reported as a failed fit (eq. 7.2) rather than a face.
    aam = imm_fit_model.aam
    c = np.full(aam.n_appearance, 50.0) * np.sqrt(aam.combined.pca.variances)
    _, sim = aam.shape.fit_points(imm_test[0].points)
    fitter = Fitter(imm_fit_model, "fixed-jacobian", max_iterations=1, failure_test="eq7.2")
    result = fitter.fit(image, c, sim)
    assert result.failed and "3 sigma" in result.reason


def test_unknown_algorithm(imm_fit_model) -> None:
    with pytest.raises(ValueError, match="algorithm .newton.: choose one of local-binary"):
        Fitter(imm_fit_model, "newton")


def test_failure_tests_and_appearance_of_each_kind_of_method(imm_fit_model, imm_test) -> None:
    import math

    from aamcore.detection.haar import HaarFaceDetector

    image = imm_test[0].load_image()
    box = HaarFaceDetector().detect(image)[0]
    n, m = imm_fit_model.aam.n_appearance, imm_fit_model.aam.frame.n_pixels
    bare = Fitter(imm_fit_model, appearance=False)
    assert bare.name == "local-binary" and bare.failure_test == "quality" and not bare.warps
    plain = bare.fit_box(image, box)
    assert type(plain) is LandmarkFit and plain.ok and 0.5 < plain.confidence <= 1
    assert predicts(plain, imm_test[0], imm_fit_model.aam.scheme)  # the truth's error
    default = Fitter(imm_fit_model)
    assert default.warps
    sampled = default.fit_box(image, box)
    assert isinstance(sampled, AAMFit) and sampled.c.shape == (n,) and sampled.iterations == 0
    assert sampled.residual.shape == (m,) and math.isfinite(sampled.error)
    # the texture error of the face where it is, far below that of the face missed by a
    # tenth of its width
    missed = imm_test[0].points + [0.1 * np.ptp(imm_test[0].points[:, 0]), 0.0]
    assert sampled.error < 0.5 * default.sampler.project_frame(image, missed).error
    assert np.allclose(sampled.points, plain.points) and sampled.score == plain.score
    assert sampled.occluded is not None and sampled.occluded.shape == (len(plain.points),)
    chi2 = Fitter(imm_fit_model, failure_test="chi2", appearance=False)
    judged = chi2.fit_box(image, box)
    assert judged.c.shape == (n,) and chi2.quality is None
    assert not judged.failed and 0 < judged.confidence <= 1  # a face the model knows
    aam = Fitter(imm_fit_model, "fixed-jacobian", failure_test="quality")
    scored = aam.fit_box(image, box)
    assert math.isfinite(scored.score) and scored.c.shape == (n,) and aam.warps
    assert Fitter(imm_fit_model, "fixed-jacobian").failure_test == "chi2"


def test_the_quality_threshold_is_applied_once_by_the_fitter(imm_fit_model, imm_test) -> None:
    from aamcore.detection.haar import HaarFaceDetector

    image = imm_test[0].load_image()
    box = HaarFaceDetector().detect(image)[0]
    fitter = Fitter(imm_fit_model, appearance=False)
    raw = fitter.algorithm.fit_shape(image, imm_fit_model.mapping.place(box, "detector"))
    # The algorithm scores; it does not judge (its fit is failed only for what it cannot
    # go on from, here nothing).
    assert raw.ok and np.isnan(raw.confidence)
    judged = fitter.fit_box(image, box)
    assert judged.ok and judged.reason == "" and judged.confidence > 0.5  # the face
    # the same box on the image's corner, where there is no face: judged failed, by its score
    off = fitter.fit_box(image, np.array([5.0, 5.0, box[2], box[3]]))
    assert off.failed and "fit-quality score" in off.reason and off.confidence < 0.05
    assert off.score > imm_fit_model.binary.threshold > judged.score


def test_refinement_iterates_the_aam_from_the_landmarks(imm_fit_model, imm_test) -> None:
    from aamcore.detection.haar import HaarFaceDetector

    image = imm_test[0].load_image()
    box = HaarFaceDetector().detect(image)[0]
    plain = Fitter(imm_fit_model)
    projected = plain.fit_box(image, box)
    refined = Fitter(imm_fit_model, refine=3).fit_box(image, box)
    assert isinstance(refined, AAMFit) and 1 <= refined.iterations <= 3
    # The AAM starts from the appearance projected at the landmarks (its error is that of
    # the model instance of c, not of the landmarks) and only takes steps that lower it.
    assert refined.error == refined.errors[-1]
    assert all(b <= a for a, b in zip(refined.errors, refined.errors[1:], strict=False))
    staged = Fitter(imm_fit_model, refine=2, refine_with="supervised-descent").fit_box(image, box)
    assert isinstance(staged, AAMFit) and staged.iterations == 2 and staged.ok
    # A refined fit is a new fit, scored and judged at its own landmarks: its score
    # predicts its own error against the truth, and a good fit is judged good.
    for fit in (projected, refined, staged):
        assert predicts(fit, imm_test[0], imm_fit_model.aam.scheme)
        assert fit.ok and fit.confidence > 0.5
    with pytest.raises(ValueError, match="refine_with 'project-out-ic': choose one of"):
        Fitter(imm_fit_model, refine=2, refine_with="project-out-ic")


def test_fits_are_values(imm_fit_model, imm_test) -> None:
    from dataclasses import FrozenInstanceError

    from aamcore.detection.boxes import landmark_box

    fit = Fitter(imm_fit_model).fit_box(imm_test[0].load_image(),
                                        landmark_box(imm_test[0].points))
    for field, value in (("failed", True), ("score", 0.0), ("confidence", 1.0)):
        with pytest.raises(FrozenInstanceError):
            setattr(fit, field, value)
