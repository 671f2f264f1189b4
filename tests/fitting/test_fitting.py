import numpy as np
import pytest

from aamcore.evaluation.metrics import nme
from aamcore.fitting.algorithm import FixedJacobian
from aamcore.fitting.fitter import Fitter, Tracker
from aamcore.fitting.training.update import PerturbationScheme, train_update


def _nme(result, sample, scheme) -> float:
    return nme(result.points, sample.points, scheme)


def _true_pose_start(fitter, sample, dx=0.0, dy=0.0):
    _, t = fitter.aam.shape.fit_points(sample.points)
    t = t.copy()
    t[2] += dx
    t[3] += dy
    return np.zeros(fitter.aam.n_appearance), t


@pytest.mark.parametrize(
    "algorithm", ["fixed-jacobian", "multi-resolution", "project-out-ic", "supervised-descent"]
)
def test_fit_from_displaced_start_on_held_out_subjects(imm_fit_model, imm_test, algorithm) -> None:
    fitter = Fitter(imm_fit_model, algorithm)
    scheme = imm_fit_model.scheme
    errors, starts = [], []
    for sample in imm_test[::3]:
        c0, t0 = _true_pose_start(fitter, sample, dx=20.0)
        starts.append(nme(fitter.aam.shape_instance(c0, t0), sample.points, scheme))
        result = fitter.fit(sample.load_image(), c0, t0)
        errors.append(_nme(result, sample, scheme))
        assert result.iterations >= 1 and len(result.iteration_seconds) == result.iterations
    assert np.median(errors) < 0.05
    assert np.mean(errors) < 0.5 * np.mean(starts)


def test_haar_start_fits_held_out_faces(imm_fit_model, imm_test) -> None:
    tracker = Tracker(Fitter(imm_fit_model))
    errors = []
    for sample in imm_test[::4]:
        tracker.reset()
        result = tracker.track(sample.load_image())
        assert result is not None
        errors.append(_nme(result, sample, imm_fit_model.scheme))
    assert np.mean(errors) < 0.05


def test_tracking_reuses_the_last_fit(imm_fit_model, imm_test) -> None:
    tracker = Tracker(Fitter(imm_fit_model))
    image = imm_test[0].load_image()
    first = tracker.track(image)
    assert first is not None and first.ok and tracker.detections == 1
    again = tracker.track(image)
    assert again is not None and tracker.detections == 1
    drift = np.linalg.norm(again.points - first.points, axis=1).mean()
    assert drift < 0.02 * imm_fit_model.scheme.inter_ocular(first.points)


def test_regression_and_jacobian_updates(imm_fit_model, imm_train, imm_test) -> None:
    scheme = PerturbationScheme()
    for method in ("regression", "jacobian"):
        update = train_update(imm_fit_model, imm_train, method, scheme, max_images=10)
        assert update.R.shape == (imm_fit_model.n_appearance + 4, imm_fit_model.frame.n_pixels)
        algorithm = FixedJacobian(imm_fit_model, update)
        sample = imm_test[1]
        _, t = imm_fit_model.shape.fit_points(sample.points)
        t = t + np.array([0.0, 0.0, 12.0, -8.0])
        c0 = np.zeros(imm_fit_model.n_appearance)
        image = imm_fit_model.prepare_image(sample.load_image())
        start = nme(imm_fit_model.shape_instance(c0, t), sample.points, imm_fit_model.scheme)
        result = algorithm.run(image, c0, t)
        assert nme(result.points, sample.points, imm_fit_model.scheme) < 0.5 * start
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
        assert nme(result.points, imm_test[2].points, imm_fit_model.scheme) < 0.1


def test_bad_starts_give_clear_results(imm_fit_model, imm_test) -> None:
    fitter = Fitter(imm_fit_model)
    image = imm_test[0].load_image()
    with pytest.raises(ValueError, match="box"):
        fitter.fit_box(image, [10, 10, 0, 0])
    with pytest.raises(ValueError, match="NaN"):
        fitter.fit_shape(image, np.full((imm_fit_model.scheme.n_points, 2), np.nan))
    # A box mostly outside the image still gives a result, flagged or not, never a crash.
    result = fitter.fit_box(image, [700, 500, 300, 300])
    assert result.points.shape == (imm_fit_model.scheme.n_points, 2)
    # A far-off start is reported as a failed fit (eq. 7.2) rather than a face.
    c = np.full(imm_fit_model.n_appearance, 50.0) * np.sqrt(imm_fit_model.combined.pca.variances)
    _, t = imm_fit_model.shape.fit_points(imm_test[0].points)
    result = Fitter(imm_fit_model, "fixed-jacobian", max_iterations=1).fit(image, c, t)
    assert result.failed and "3 sigma" in result.reason


def test_unknown_algorithm(imm_fit_model) -> None:
    with pytest.raises(ValueError, match="unknown fitting algorithm"):
        Fitter(imm_fit_model, "newton")
