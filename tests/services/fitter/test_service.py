"""services.fitter.service: both warp paths agree, fit messages, the warp started only when
something warps and falling back to the CPU mid-run, the detector fallback."""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import numpy as np
import pytest

from aamcore.detection.haar import HaarFaceDetector
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel
from aamcore.fitting.result import AAMFit, LandmarkFit
from aamcore.fitting.warps import FitterWarp
from aamcore.model.similarity import Similarity
from aamcore.operators.faces import NO_FACE, FaceFit
from aamcore.operators.fit import FitOperator
from aamcore.operators.options import PIPELINE
from aamcore.warp.reference_frame import ReferenceFrame
from proto import Header, decode, encode
from services.bus.connection import BusOptions
from services.bus.session import Service
from services.detector.client import ServiceDetector
from services.messages import fit_message

TEXTURE_MEAN_TOLERANCE = 0.5
"""Largest mean difference in grey levels between the GPU's and the CPU's texture of one
face at the same landmarks (about 0.16 measured: rounding of the same bilinear samples)."""
TEXTURE_MAX_TOLERANCE = 2.0
"""Largest difference of any pixel between them."""


def frames(video: Path, indices: tuple[int, ...]) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(video))
    out, k = [], 0
    while len(out) < len(indices):
        ok, image = cap.read()
        assert ok
        if k in indices:
            out.append(image)
        k += 1
    cap.release()
    return out


def test_gpu_and_cpu_warps_sample_the_same_texture(model_path: Path, single_face: Path
                                                   ) -> None:
    model = FittingModel.load(model_path)
    images = frames(single_face, (0, 20, 40, 60))
    box = HaarFaceDetector().detect(images[0])[0]
    shapes = [Fitter(model).fit_box(image, box).points for image in images]
    textures = {}
    for prefer in ("gpu", "cpu"):
        warp = FitterWarp(model.aam, prefer)
        try:
            # an AAM method: its iterations warp through the fitter's warp
            fitter = Fitter(model, "supervised-descent", warp=warp)
            fits = [fitter.fit_box(image, box) for image in images]
            assert all(isinstance(fit, AAMFit) for fit in fits)
            assert warp.path == prefer, "no GL context: the GPU path cannot be compared"
            assert warp.take_path() == prefer and warp.counts[prefer] >= len(images)
            textures[prefer] = [warp.warp(image, shape).astype(np.float64)
                                for image, shape in zip(images, shapes, strict=True)]
        finally:
            warp.close()
    for gpu, cpu in zip(textures["gpu"], textures["cpu"], strict=True):
        # the same bilinear samples up to rounding (iterative fits from a box amplify
        # such differences, so the fits themselves are not compared)
        assert np.abs(gpu - cpu).mean() <= TEXTURE_MEAN_TOLERANCE
        assert np.abs(gpu - cpu).max() <= TEXTURE_MAX_TOLERANCE


def test_the_default_method_samples_its_appearance_without_the_gl_worker(
    model_path: Path, single_face: Path
) -> None:
    model = FittingModel.load(model_path)
    image = frames(single_face, (0,))[0]
    box = HaarFaceDetector().detect(image)[0]
    warp = FitterWarp(model.aam, "gpu")
    try:
        fit = Fitter(model, warp=warp).fit_box(image, box)
        assert isinstance(fit, AAMFit) and np.all(np.isfinite(fit.c))
        assert warp.counts["gpu"] == 0  # the sampler warps the grey region on the CPU
    finally:
        warp.close()


def test_the_gl_worker_starts_only_when_something_warps(model_path: Path) -> None:
    model = FittingModel.load(model_path)
    op = FitOperator(model, PIPELINE.fit.with_values(warp="gpu", appearance=False))
    op.warm_up()
    assert not op.fitter.warps and not op.warp.started and op.warp.path == "none"
    op = FitOperator(model, PIPELINE.fit.with_values(warp="gpu"))
    try:
        op.warm_up()
        assert op.fitter.warps and op.warp.started and op.warp.path == "gpu"
        assert op.warp.counts == {"gpu": 0, "cpu": 0}  # the warm-up's warps are not counted
    finally:
        op.close()


def test_a_gl_warp_that_fails_mid_run_falls_back_to_the_cpu(
    model_path: Path, single_face: Path, caplog: pytest.LogCaptureFixture
) -> None:
    model = FittingModel.load(model_path)
    image = frames(single_face, (0,))[0]
    box = HaarFaceDetector().detect(image)[0]
    warp = FitterWarp(model.aam, "gpu")
    fitter = Fitter(model, "supervised-descent", warp=warp)
    first = fitter.fit_box(image, box)
    assert warp.take_path() == "gpu" and isinstance(first, AAMFit)
    warp._warp.close()  # the GL thread goes away, as a lost context would take it
    with caplog.at_level(logging.WARNING):
        again = fitter.fit_box(image, box)
    assert isinstance(again, AAMFit) and warp.take_path() == "cpu" and warp.path == "cpu"
    assert any("warping on the CPU from now on" in r.getMessage() for r in caplog.records)
    # from then on the fitter fits exactly as one that warps on the CPU from the start
    alone = Fitter(model, "supervised-descent", warp=FitterWarp(model.aam, "cpu"))
    expected = alone.fit_box(image, box)
    np.testing.assert_allclose(again.points, expected.points)
    assert again.error == pytest.approx(expected.error) and again.ok == expected.ok


FRAME = ReferenceFrame.from_mean_shape(np.array([[0.0, 0.0], [8.0, 0.0], [0.0, 6.0], [8.0, 6.0]]))
"""A small reference frame of two triangles."""


def _result(points: np.ndarray, failed: bool = False, reason: str = "") -> AAMFit:
    flags = np.zeros(len(points), bool)
    flags[:5] = True
    return AAMFit(points=points, similarity=Similarity(1.1, 0.0, 5.0, 6.0), failed=failed,
                  reason=reason, confidence=0.0 if failed else 0.75, c=np.zeros(3),
                  residual=np.full(FRAME.n_pixels, 0.5, np.float32), error=0.25, iterations=4,
                  occluded=None if failed else flags)


def message(header: Header, fit: LandmarkFit | None, warp_path: str, size: tuple[int, int],
            face_id: int = 0, faces: int = 1) -> object:
    """The fitter's message of ``fit`` as the fit operator hands it on."""
    entry = FaceFit.of(face_id if fit is not None and fit.ok else -1, fit, "ibug68")
    return fit_message(header, entry, warp_path, size, FRAME, faces)


def test_fit_messages_for_good_failed_lost_and_broken_results() -> None:
    header = Header.now("cam0", 3, "fitter")
    points = np.random.default_rng(0).uniform(10, 200, (68, 2))
    size = (640, 480)
    good = decode(encode(message(header, _result(points), "gpu", size)),
                  "fit")
    assert not good.failed and good.warp_path == "gpu" and good.confidence == 0.75
    found = good.appearance
    assert found is not None and found.converged and found.iterations == 4
    assert found.texture_error == 0.25 and found.occluded.tolist() == [1] * 5 + [0] * 63
    assert found.texture_residual.shape == FRAME.size
    assert np.allclose(found.texture_residual[FRAME.mask], 0.5)
    assert np.all(found.texture_residual[~FRAME.mask] == 0)
    assert (good.image_width, good.image_height) == (640, 480)
    assert np.allclose(good.similarity, [1.1, 0.0, 5.0, 6.0])
    assert np.allclose(good.landmarks, points, atol=1e-3)
    failed = message(header, _result(points, True, "beyond 3 sigma"), "cpu", size)
    assert failed.failed and failed.failure_reason == "beyond 3 sigma" and len(failed.landmarks)
    assert failed.appearance is not None and failed.appearance.occluded.shape == (0,)
    lost = message(header, None, "none", (640, 480))
    assert lost.failed and lost.failure_reason == NO_FACE and lost.landmarks.shape == (0, 2)
    assert lost.appearance is None and lost.warp_path == "none"
    assert (good.face_id, failed.face_id, lost.face_id) == (0, -1, -1)
    assert (good.faces, failed.faces, lost.faces) == (1, 1, 1)
    second = message(header, _result(points), "gpu", size, 7, 3)
    assert (second.face_id, second.faces) == (7, 3)
    broken = message(header, _result(np.full((68, 2), np.nan)), "cpu", (640, 480))
    assert broken.failed and broken.failure_reason == "non-finite result"
    assert broken.landmarks.shape == (0, 2) and broken.appearance is None
    # a landmark regressor's fit without the appearance: nothing was warped
    bare = LandmarkFit(points, Similarity(1.1, 0.0, 5.0, 6.0), confidence=0.9, score=-3.5)
    plain = decode(encode(message(header, bare, "none", size)), "fit")
    assert not plain.failed and plain.appearance is None and plain.warp_path == "none"
    assert plain.confidence == pytest.approx(0.9) and plain.c is None


def test_without_a_detector_service_the_fitter_detects_locally_and_says_so(
    bus_pair: tuple[BusOptions, BusOptions], single_face: Path, caplog: pytest.LogCaptureFixture
) -> None:
    image = frames(single_face, (0,))[0]
    with caplog.at_level(logging.WARNING), Service("fitter", bus_pair[0],
                                                   handle_signals=False) as svc:
        detector = ServiceDetector(svc, timeout=0.3, local_for=60.0)
        detector.set_frame(image, b"")
        first = detector.detect(image)
        second = detector.detect(image)
    assert len(first) >= 1 and np.array_equal(first, second)
    assert detector.queries == 1 and detector.local_detections == 2
    warnings = [r.getMessage() for r in caplog.records if "did not answer" in r.getMessage()]
    assert len(warnings) == 1


def test_a_query_about_a_turned_copy_of_the_frame_carries_that_copy(
    bus_pair: tuple[BusOptions, BusOptions], single_face: Path
) -> None:
    from aamcore.fitting.upright import rotated_view

    image = frames(single_face, (0,))[0]
    with Service("fitter", bus_pair[0], handle_signals=False) as svc:
        detector = ServiceDetector(svc, timeout=0.3, local_for=60.0)
        detector.set_frame(image, b"the frame's own bytes")
        assert detector._query_for(image)[0] == b"the frame's own bytes"
        view, _ = rotated_view(image, 0.5)
        sent = decode(detector._query_for(view)[0], "frame")
    assert np.array_equal(sent.image, view)
