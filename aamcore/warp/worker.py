"""A thread that owns the OpenGL context and warps on behalf of the fitting thread.

An OpenGL context is current in one thread only, so (as in thesis appendix B,
where a dedicated POSIX thread ran the OpenGL state machine) the GL warp lives
in its own thread. :class:`GLWarpWorker` creates the EGL context inside that
thread and serves requests passed through a pair of :class:`queue.Queue`
objects (producer-consumer, like the thesis's two mutexes ``glJob`` and
``glDone``). It offers the CPU warp's call, ``warp(image, shape) -> (M, C)``,
plus :meth:`GLWarpWorker.set_frame` to upload a video frame once for all the
iterations of a fit.

:func:`aamcore.fitting.warps.make_warp` picks the GL worker or the CPU warp, falling back to the
CPU when no GL context can be made.
"""

from __future__ import annotations

import logging
import queue
import threading
from typing import Any, Protocol

import moderngl
import numpy as np

from aamcore.warp.gl import GLWarp
from aamcore.warp.piecewise_affine import PiecewiseAffineWarp
from aamcore.warp.reference_frame import ReferenceFrame

logger = logging.getLogger(__name__)

START_TIMEOUT = 30.0
"""Seconds to wait for the GL thread to create its context (the first takes about 1 s)."""

_POLL = 0.5  # seconds between checks that the other side is still alive
_STOP = "stop"
_UPLOAD = "upload"
_WARP = "warp"
_PING = "ping"
_logged_fallbacks: set[str] = set()


class GLUnavailableError(RuntimeError):
    """No OpenGL context or GL warp could be made; the message says why."""


class Warp(Protocol):
    """What the fitter calls: a warp into the reference frame, GL or CPU.

    :class:`GLWarpWorker` and :class:`CPUWarp` both have this interface (and
    are callable as ``warp(image, shape)`` too).
    """

    n_pixels: int

    def warp(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray: ...

    def set_frame(self, image: np.ndarray) -> None: ...

    def close(self) -> None: ...


class GLWarpWorker:
    """Serve :class:`GLWarp` calls from a thread that owns the GL context.

    Parameters
    ----------
    frame : ReferenceFrame
    n_points : int
        Number of landmarks.
    backend : str
        moderngl standalone backend (``"egl"`` for headless rendering).

    Raises
    ------
    GLUnavailableError
        If the thread cannot create the context or the warp; the cause is chained.

    Notes
    -----
    The thread is not a daemon: :meth:`close` stops and joins it (use the
    worker as a context manager). A worker left open stops by itself once the
    main thread has finished, so a forgotten ``close`` does not hang the
    interpreter at exit. Calls from several threads are serialised.
    """

    def __init__(self, frame: ReferenceFrame, n_points: int, backend: str = "egl") -> None:
        self.n_points = n_points
        self.n_pixels = frame.n_pixels
        self._requests: queue.Queue[tuple[str, Any, Any]] = queue.Queue()
        self._responses: queue.Queue[tuple[bool, Any]] = queue.Queue()
        self._lock = threading.Lock()
        self._current: np.ndarray | None = None
        self._closed = False
        self._thread = threading.Thread(
            target=self._serve, args=(frame, n_points, backend), name="gl-warp", daemon=False
        )
        self._thread.start()
        try:
            ok, payload = self._responses.get(timeout=START_TIMEOUT)
        except queue.Empty:
            self._closed = True
            raise GLUnavailableError(
                f"the GL thread did not start within {START_TIMEOUT:.0f} s"
            ) from None
        if not ok:
            self._closed = True
            self._thread.join()
            raise GLUnavailableError(
                f"cannot make a GL warp with backend {backend!r}: {payload}"
            ) from payload
        self.renderer: str = payload

    def __enter__(self) -> GLWarpWorker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __call__(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        return self.warp(image, shape)

    @property
    def alive(self) -> bool:
        """Whether the GL thread is running and accepting requests."""
        return not self._closed and self._thread.is_alive()

    def set_frame(self, image: np.ndarray) -> None:
        """Upload ``image`` (H, W) or (H, W, 3) uint8, the frame that later warps sample."""
        self._request(_UPLOAD, image, None)

    def warp(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Texture (M, C) float32 ((M,) for grey) of ``image`` inside ``shape`` (N, 2).

        ``image`` is uploaded unless it is the very object last passed to
        :meth:`set_frame` or :meth:`warp`: a caller that refills one buffer in
        place must call :meth:`set_frame` for every new frame.
        """
        return self._request(_WARP, image, shape)

    def ping(self) -> None:
        """A request that does no GL work: its time is the thread round trip."""
        self._request(_PING, None, None)

    def close(self, timeout: float = 10.0) -> None:
        """Stop the GL thread, release its context and join it. Safe to call twice."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._requests.put((_STOP, None, None))
        self._thread.join(timeout)
        if self._thread.is_alive():
            raise RuntimeError(f"the GL thread did not stop within {timeout} s")

    def _request(self, op: str, image: np.ndarray | None, shape: np.ndarray | None) -> Any:
        with self._lock:
            if self._closed:
                raise RuntimeError("the GL warp worker is closed")
            send = image
            if op == _WARP and image is self._current:
                send = None  # already the uploaded texture
            self._requests.put((op, send, shape))
            ok, payload = self._await_response()
            if op in (_UPLOAD, _WARP):
                # After a failure the texture may hold anything: upload next time.
                self._current = image if ok else None
        if not ok:
            raise payload
        return payload

    def _await_response(self) -> tuple[bool, Any]:
        while True:
            try:
                return self._responses.get(timeout=_POLL)
            except queue.Empty:
                if not self._thread.is_alive():
                    self._closed = True
                    raise RuntimeError("the GL thread died") from None

    def _serve(self, frame: ReferenceFrame, n_points: int, backend: str) -> None:
        """The GL thread: make the context, then answer requests until told to stop."""
        try:
            ctx = moderngl.create_standalone_context(backend=backend)
        except Exception as exc:
            self._responses.put((False, exc))
            return
        try:
            gl_warp = GLWarp(frame, n_points, ctx)
        except Exception as exc:
            ctx.release()
            self._responses.put((False, exc))
            return
        self._responses.put((True, gl_warp.renderer))
        try:
            self._answer(gl_warp)
        finally:
            gl_warp.release()
            ctx.release()

    def _answer(self, gl_warp: GLWarp) -> None:
        main = threading.main_thread()
        while True:
            try:
                op, image, shape = self._requests.get(timeout=_POLL)
            except queue.Empty:
                if not main.is_alive():
                    return
                continue
            if op == _STOP:
                return
            if op == _PING:
                self._responses.put((True, None))
                continue
            try:
                if image is not None:
                    gl_warp.upload(image)
                result = gl_warp.warp(shape) if op == _WARP else None
            except Exception as exc:
                self._responses.put((False, exc))
            else:
                self._responses.put((True, result))


class CPUWarp:
    """The CPU warp behind the same interface as :class:`GLWarpWorker`.

    Parameters
    ----------
    warp : PiecewiseAffineWarp
    """

    renderer = "cpu (cv2.remap)"

    def __init__(self, warp: PiecewiseAffineWarp) -> None:
        self._warp = warp
        self.n_pixels = warp.n_pixels

    def __enter__(self) -> CPUWarp:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __call__(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        return self._warp.warp(image, shape)

    def warp(self, image: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Texture (M, C) float32 ((M,) for grey) of ``image`` inside ``shape`` (N, 2)."""
        return self._warp.warp(image, shape)

    def set_frame(self, image: np.ndarray) -> None:
        """Nothing to upload on the CPU."""

    def close(self) -> None:
        """Nothing to release on the CPU."""


def log_fallback_once(reason: str) -> None:
    """Log once per process that the GL warp is not used, and why."""
    if reason not in _logged_fallbacks:
        _logged_fallbacks.add(reason)
        logger.warning("GL warp unavailable, using the CPU warp: %s", reason)
