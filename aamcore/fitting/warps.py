"""The fitter's warp: the GL worker or the CPU, started when something warps, counted per path.

:class:`FitterWarp` is what a fitter is given as its texture sampler. It
makes nothing until it is :meth:`~FitterWarp.start`-ed (the fitter service
starts it only for a fitter that warps) or first called, so a stack whose
fitter never samples a texture never creates a GL context. It then warps on
the path :func:`make_warp` chooses, counts every warp and
its time by path, and tells after each fit which path the fit's warps took
(``none`` for a fit that warped nothing). A GL warp that fails mid-run (the
GL thread died, the context was lost) is logged once and the warps go on on
the CPU.
"""

from __future__ import annotations

import logging
import time
from typing import Literal

import numpy as np

from aamcore.model.aam import AAM
from aamcore.warp.worker import (
    CPUWarp,
    GLUnavailableError,
    GLWarpWorker,
    Warp,
    log_fallback_once,
)

logger = logging.getLogger(__name__)

Path = Literal["gpu", "cpu"]
PATHS: tuple[Path, ...] = ("gpu", "cpu")


class FitterWarp:
    """A warp ``(image, shape) -> (M, C)`` on the GPU worker or the CPU, made when needed.

    Parameters
    ----------
    aam : AAM
    prefer : {"auto", "gpu", "cpu"}
        As :func:`make_warp` takes it.
    backend : str
        moderngl standalone backend for the GL context.

    Attributes
    ----------
    counts : dict of str to int
        Warps done on each path.
    seconds : dict of str to float
        Time spent in them, by path (including the GL thread's round trip).
    """

    def __init__(self, aam: AAM, prefer: Literal["auto", "gpu", "cpu"] = "auto",
                 backend: str = "egl") -> None:
        if prefer not in ("auto", "gpu", "cpu"):
            raise ValueError(f"prefer must be 'auto', 'gpu' or 'cpu', got {prefer!r}")
        self.aam = aam
        self.prefer = prefer
        self.backend = backend
        self.counts: dict[str, int] = dict.fromkeys(PATHS, 0)
        self.seconds: dict[str, float] = dict.fromkeys(PATHS, 0.0)
        self._warp: Warp | None = None
        self._path: Path | None = None
        self._used: set[str] = set()

    @property
    def started(self) -> bool:
        """Whether a warp (a GL worker or the CPU's) has been made."""
        return self._warp is not None

    @property
    def path(self) -> str:
        """Where warps run now: ``gpu``, ``cpu``, or ``none`` before the start."""
        return self._path or "none"

    @property
    def renderer(self) -> str:
        """The GL renderer, or the CPU warp's name ("" before the start)."""
        return str(getattr(self._warp, "renderer", ""))

    def start(self) -> str:
        """Make the warp now (the GL worker's context takes about a second); its path."""
        if self._warp is None:
            self._warp, self._path = make_warp(self.aam, self.prefer, self.backend)
        return self.path

    def __call__(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        return self.warp(image, shape)

    def warp(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Texture (M, C) float32 ((M,) for grey) of ``image`` inside ``shape`` (N, 2)."""
        self.start()
        path = self._path
        begun = time.perf_counter()
        if path == "gpu":
            try:
                texture = self._warp.warp(image, shape)  # type: ignore[union-attr]
            except ValueError:  # this shape or image (e.g. non-finite): the CPU's answer
                path = "cpu"
                texture = self.aam.warp.warp(image, shape)
            except Exception as exc:  # the GL path is gone: the CPU from now on
                self._fall_back(exc)
                path = "cpu"
                texture = self.aam.warp.warp(image, shape)
        else:
            texture = self._warp.warp(image, shape)  # type: ignore[union-attr]
        self.counts[path] += 1  # type: ignore[index]
        self.seconds[path] += time.perf_counter() - begun  # type: ignore[index]
        self._used.add(path)  # type: ignore[arg-type]
        return texture

    def record(self, path: str, seconds: float) -> None:
        """Count a warp done elsewhere on ``path`` (the appearance's box, on the CPU)."""
        self.counts[path] += 1  # type: ignore[index]
        self.seconds[path] += seconds  # type: ignore[index]
        self._used.add(path)  # type: ignore[arg-type]

    def set_frame(self, image: np.ndarray) -> None:
        """Upload the frame the next warps sample, on the GPU path (nothing on the CPU)."""
        if self._path == "gpu":
            try:
                self._warp.set_frame(image)  # type: ignore[union-attr]
            except Exception as exc:
                self._fall_back(exc)

    def take_path(self) -> str:
        """The path the warps since the last call took (``gpu``, ``cpu``, or ``none`` for
        no warp; ``gpu`` when some fell back), and forget them."""
        used, self._used = self._used, set()
        if not used:
            return "none"
        return "gpu" if "gpu" in used else "cpu"

    def ms_per_warp(self, path: str) -> float:
        """Mean milliseconds of a warp on ``path`` (NaN before any)."""
        n = self.counts.get(path, 0)
        return 1000.0 * self.seconds[path] / n if n else float("nan")

    def summary(self) -> str:
        """``warps gpu N (X ms), cpu M (Y ms)``: the counts and mean times so far."""
        parts = [f"{p} {self.counts[p]}" + (f" ({self.ms_per_warp(p):.3f} ms)"
                                            if self.counts[p] else "") for p in PATHS]
        return "warps " + ", ".join(parts)

    def _fall_back(self, exc: Exception) -> None:
        logger.warning("the GL warp failed (%s: %s): warping on the CPU from now on",
                       type(exc).__name__, exc)
        worker = self._warp
        self._warp, self._path = make_warp(self.aam, "cpu")
        if isinstance(worker, GLWarpWorker):
            try:
                worker.close(timeout=2.0)
            except RuntimeError as err:
                logger.warning("the GL thread did not stop: %s", err)

    def close(self) -> None:
        """Release the GL worker, if one was made (a later warp makes the warp again)."""
        if self._warp is not None:
            self._warp.close()
            self._warp = self._path = None


SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swiftshader", "software")
"""GL renderers that rasterise on the CPU: there the CPU warp is faster."""
GPU_MIN_PIXELS = 20_000
"""Reference pixels from which ``auto`` warps on a GPU: timed on an NVIDIA H200 with the
frame's upload and the worker's round trip, the GL worker takes 0.098 ms a warp against the
CPU's 0.035 at 2,409 pixels (the default model: the stack 10-45 % slower on the GPU for every
AAM method), 0.158 against 0.143 at 9,934 and 0.273 against 0.405 at 29,837 (notes of issue 33)."""


def make_warp(
    aam: AAM, prefer: Literal["auto", "gpu", "cpu"] = "auto", backend: str = "egl"
) -> tuple[Warp, Literal["gpu", "cpu"]]:
    """The warp a fitter should use for ``aam``, and which path it is.

    Parameters
    ----------
    aam : AAM
    prefer : {"auto", "gpu", "cpu"}
        ``"gpu"`` tries a :class:`GLWarpWorker` first and falls back to the
        CPU warp when no GL context can be made (the reason is logged once per
        process); ``"cpu"`` uses the CPU warp directly; ``"auto"`` uses the
        GPU only for a model of at least :data:`GPU_MIN_PIXELS` reference pixels
        and a GL renderer that is a real GPU, not a software
        rasteriser such as Mesa's llvmpipe, which warps slower than OpenCV on
        the same cores.
    backend : str
        moderngl standalone backend for the GL context.

    Returns
    -------
    warp : GLWarpWorker or CPUWarp
        Has ``warp(image, shape)``, ``set_frame(image)`` and ``close()``.
    path : {"gpu", "cpu"}
    """
    if prefer not in ("auto", "gpu", "cpu"):
        raise ValueError(f"prefer must be 'auto', 'gpu' or 'cpu', got {prefer!r}")
    if prefer == "gpu" or (prefer == "auto" and aam.frame.n_pixels >= GPU_MIN_PIXELS):
        try:
            worker = GLWarpWorker(aam.frame, aam.shape.n_points, backend)
        except GLUnavailableError as exc:
            log_fallback_once(str(exc))
        else:
            if prefer == "gpu" or not any(
                name in worker.renderer.lower() for name in SOFTWARE_RENDERERS
            ):
                return worker, "gpu"
            worker.close()
            log_fallback_once(f"software GL renderer {worker.renderer}: the CPU warp is faster")
    return CPUWarp(aam.warp), "cpu"
