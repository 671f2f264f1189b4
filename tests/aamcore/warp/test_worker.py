"""The GL warp thread: requests, errors, shutdown, the CPU fallback, and what ``auto``
chooses, from facts found outside the warp (the model's size, the GL renderer)."""

from __future__ import annotations

import logging
import threading

import moderngl
import numpy as np
import pytest

from aamcore.fitting import warps
from aamcore.fitting.warps import make_warp
from aamcore.warp.worker import CPUWarp, GLUnavailableError, GLWarpWorker

MEAN_DIFF = 0.5  # grey levels; see test_gl_warp.py


@pytest.fixture(scope="module")
def worker(imm_model):
    with GLWarpWorker(imm_model.frame, imm_model.shape.n_points) as w:
        yield w


@pytest.fixture(scope="module")
def faces(imm_set) -> list:
    return [s for s in imm_set.samples if int(s.subject) >= 10][:3]


def _mean_diff(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).mean())


def test_worker_serves_warps_like_the_cpu(worker: GLWarpWorker, imm_model, faces) -> None:
    first, second = faces[0].load_image(), faces[1].load_image()
    worker.set_frame(first)
    for _ in range(2):  # the uploaded frame serves repeated warps
        out = worker.warp(first, faces[0].points)
        assert out.shape == (imm_model.frame.n_pixels, 3)
        assert _mean_diff(out, imm_model.warp.warp(first, faces[0].points)) < MEAN_DIFF
    # A different image is uploaded by warp itself.
    out = worker(second, faces[1].points)
    assert _mean_diff(out, imm_model.warp.warp(second, faces[1].points)) < MEAN_DIFF


def test_set_frame_uploads_a_buffer_refilled_in_place(worker, imm_model, faces) -> None:
    buffer = faces[0].load_image()
    worker.set_frame(buffer)
    worker.warp(buffer, faces[0].points)
    buffer[:] = faces[2].load_image()
    worker.set_frame(buffer)
    out = worker.warp(buffer, faces[2].points)
    assert _mean_diff(out, imm_model.warp.warp(buffer, faces[2].points)) < MEAN_DIFF


def test_errors_in_the_gl_thread_reach_the_caller(worker: GLWarpWorker, imm_model, faces) -> None:
    image = faces[0].load_image()
    with pytest.raises(ValueError, match=r"shape must be \(73, 2\)"):
        worker.warp(image, faces[0].points[:20])
    with pytest.raises(ValueError, match="uint8"):
        worker.set_frame(image.astype(np.float64))
    assert worker.alive  # and it goes on serving
    out = worker.warp(image, faces[0].points)
    assert _mean_diff(out, imm_model.warp.warp(image, faces[0].points)) < MEAN_DIFF


def test_calls_from_several_threads_are_serialised(worker, imm_model, faces) -> None:
    images = [f.load_image() for f in faces]
    # The CPU warp reuses its map buffer, so it is computed here, in one thread.
    expected = [imm_model.warp.warp(images[k], faces[k].points).copy() for k in range(3)]
    errors: list[float] = []

    def run(k: int) -> None:
        for _ in range(10):
            out = worker.warp(images[k], faces[k].points)
            errors.append(_mean_diff(out, expected[k]))

    threads = [threading.Thread(target=run, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(errors) == 30 and max(errors) < MEAN_DIFF


def test_close_joins_the_thread(imm_model, faces) -> None:
    worker = GLWarpWorker(imm_model.frame, imm_model.shape.n_points)
    worker.ping()
    thread = worker._thread
    assert thread.is_alive() and not thread.daemon
    worker.close()
    assert not thread.is_alive() and not worker.alive
    worker.close()  # twice is fine
    with pytest.raises(RuntimeError, match="closed"):
        worker.warp(faces[0].load_image(), faces[0].points)


def test_an_unusable_backend_is_a_clear_error(imm_model) -> None:
    with pytest.raises(GLUnavailableError, match="no-such-backend") as info:
        GLWarpWorker(imm_model.frame, imm_model.shape.n_points, backend="no-such-backend")
    assert info.value.__cause__ is not None


def test_make_warp_prefers_the_gpu(imm_model, faces) -> None:
    warp, path = make_warp(imm_model, prefer="gpu")
    with warp:
        assert path == "gpu" and isinstance(warp, GLWarpWorker)
    warp, path = make_warp(imm_model, prefer="cpu")
    assert path == "cpu" and isinstance(warp, CPUWarp)
    image = faces[0].load_image()
    warp.set_frame(image)
    np.testing.assert_array_equal(
        warp.warp(image, faces[0].points), imm_model.warp.warp(image, faces[0].points)
    )
    with pytest.raises(ValueError, match="prefer"):
        make_warp(imm_model, prefer="tpu")


def test_make_warp_falls_back_to_the_cpu(imm_model, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING, logger="aamcore.warp.worker")
    for _ in range(2):
        warp, path = make_warp(imm_model, prefer="gpu", backend="fallback-test-backend")
        assert path == "cpu" and isinstance(warp, CPUWarp)
    reasons = [r.getMessage() for r in caplog.records if "fallback-test-backend" in r.getMessage()]
    assert len(reasons) == 1 and "using the CPU warp" in reasons[0]


SOFTWARE_RASTERISERS = ("llvmpipe", "softpipe", "swiftshader")
"""How the software GL rasterisers name themselves (Mesa's two, Google's SwiftShader): a
renderer that rasterises on the CPU cores, where OpenCV's warp is faster."""


def gl_renderer() -> str:
    """The renderer of a GL context made here, as its driver names it."""
    ctx = moderngl.create_standalone_context(backend="egl")
    try:
        return str(ctx.info["GL_RENDERER"])
    finally:
        ctx.release()


def chosen(imm_model) -> str:
    warp, path = make_warp(imm_model, "auto")
    try:
        assert isinstance(warp, GLWarpWorker if path == "gpu" else CPUWarp)
        return path
    finally:
        warp.close()


def test_auto_uses_the_cpu_for_a_model_below_the_documented_size(imm_model) -> None:
    # the documented threshold (the GL worker gains from about 30,000 reference pixels)
    assert imm_model.frame.n_pixels < 20_000 <= warps.GPU_MIN_PIXELS
    assert chosen(imm_model) == "cpu"  # whatever renderer this machine has: no context made


def test_auto_uses_the_gpu_for_a_large_model_on_a_real_gpu_only(
        imm_model, monkeypatch: pytest.MonkeyPatch) -> None:
    # the IMM model taken as large: the choice is then the renderer's
    monkeypatch.setattr(warps, "GPU_MIN_PIXELS", imm_model.frame.n_pixels)
    renderer = gl_renderer().lower()
    software = any(name in renderer for name in SOFTWARE_RASTERISERS)
    assert chosen(imm_model) == ("cpu" if software else "gpu"), renderer


def test_auto_takes_the_gl_worker_when_the_renderer_counts_as_a_gpu(
        imm_model, monkeypatch: pytest.MonkeyPatch) -> None:
    """On a machine without a GPU, this machine's renderer counted as one: a large model gets
    the GL worker, a small one the CPU (what a GPU machine's auto does, with a real GL
    context and worker)."""
    monkeypatch.setattr(warps, "SOFTWARE_RENDERERS", ())
    monkeypatch.setattr(warps, "GPU_MIN_PIXELS", imm_model.frame.n_pixels)
    assert chosen(imm_model) == "gpu"
    monkeypatch.setattr(warps, "GPU_MIN_PIXELS", imm_model.frame.n_pixels + 1)
    assert chosen(imm_model) == "cpu"
