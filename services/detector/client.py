"""Asking the detector service for face boxes, with a local Haar detector as fallback.

A query goes to every queryable on the detector's key (another program may declare one
too), and its replies come as they arrive, none consolidated into another: the first reply
signed by the run's detector for the frame asked about is the answer, at once; any other
(unsigned, another's, for another frame, malformed, an error) is counted as rejected, and
a queryable that holds the query back costs nothing once the detector has answered.
"""

from __future__ import annotations

import json
import threading
import time
from typing import Any

import numpy as np

from aamcore.detection.haar import HaarFaceDetector
from proto import Frame, Header, ProtoError, decode
from proto.keys import detect_key
from services.bus.session import Service

MAX_SETTINGS_BYTES = 1024
"""The longest settings attachment read from a detector reply."""


class ServiceDetector:
    """Face detection through the detector service (a Zenoh querier), with a local fallback.

    Has the ``detect(image) -> (K, 4)`` call that :class:`aamcore.fitting.tracker.Tracker`
    expects. :meth:`set_frame` names the decoded image of the frame message
    about to be tracked, so that a query about it carries the bytes received
    rather than a re-encoding; any other image (the tracker asks about turned
    copies of the frame too) is encoded for its query.

    Parameters
    ----------
    svc : Service
    timeout : float
        Seconds to wait for the service's reply.
    local_for : float
        Seconds to detect locally after the service failed to answer.
    """

    def __init__(self, svc: Service, timeout: float, local_for: float) -> None:
        self.svc = svc
        self.timeout = timeout
        self.local_for = local_for
        self.queries = 0
        self.local_detections = 0
        self._querier = svc.querier(detect_key(svc.stream), timeout, every_reply=True)
        self._local: HaarFaceDetector | None = None
        self._settings: dict[str, Any] | None = None
        """The detector service's settings, from its latest reply; the local fall-back
        searches with them (the library's defaults before any reply)."""
        self._local_until = 0.0
        self._image: np.ndarray | None = None
        self._payload = b""
        self._header: Header | None = None

    def set_frame(self, image: np.ndarray, payload: bytes, header: Header | None = None
                  ) -> None:
        """The decoded image of the frame message about to be tracked, the message's
        bytes and its header."""
        self._image, self._payload, self._header = image, payload, header

    def detect(self, image: np.ndarray) -> np.ndarray:
        """Face boxes ``(K, 4)`` float64 ``x, y, w, h`` in ``image``, largest first."""
        if time.monotonic() >= self._local_until:
            boxes = self._ask(image)
            if boxes is not None:
                return boxes
            self._local_until = time.monotonic() + self.local_for
            self.svc.log.warning(
                "the detector service did not answer within %g s: detecting locally for %g s",
                self.timeout, self.local_for)
        return self._detect_locally(image)

    def _query_for(self, image: np.ndarray) -> tuple[bytes, Header | None]:
        """The frame message to ask about ``image`` (signed by its producer) and its header."""
        if image is self._image:
            return self._payload, self._header
        height, width = image.shape[:2]
        frame = Frame(self.svc.header(0), "raw", width, height, image)
        return self.svc.encode(frame), frame.header

    def _ask(self, image: np.ndarray) -> np.ndarray | None:
        self.queries += 1
        payload, asked = self._query_for(image)
        answered = threading.Event()
        got: list[tuple[np.ndarray, Any]] = []
        lock = threading.Lock()

        def on_reply(reply: Any) -> None:
            boxes, why = self._judge(reply, asked, image.shape)
            with lock:
                if boxes is not None and not got:
                    got.append((boxes, reply.ok.attachment))
                    answered.set()
                    return
            self.svc.reject("detector reply", why or "a second reply of the detector")

        import zenoh

        self._querier.get(zenoh.handlers.Callback(on_reply), payload=payload)
        if not answered.wait(self.timeout):
            return None
        boxes, attachment = got[0]
        self._adopt(attachment)
        return boxes

    def _judge(self, reply: Any, asked: Header | None, shape: tuple[int, ...]
               ) -> tuple[np.ndarray | None, str]:
        """The boxes of a reply signed by the run's detector for the frame asked about, or
        why it is not one."""
        if reply.ok is None:
            return None, f"error reply: {_err_text(reply)}"
        payload = reply.ok.payload.to_bytes()
        try:
            boxes = decode(payload, "boxes")
        except ProtoError as exc:
            return None, exc.reason
        if boxes.header.producer != "detector":
            return None, f"boxes of {boxes.header.producer!r}, not the detector's"
        keyring = self.svc.keyring
        problem = keyring.problem(payload, boxes) if keyring else ""
        if problem:
            return None, f"boxes not the run's detector's: {problem}"
        if asked is not None and (boxes.header.capture_time_ns, boxes.header.frame_index) != (
                asked.capture_time_ns, asked.frame_index):
            return None, "boxes for another frame"
        if (boxes.image_width, boxes.image_height) != (shape[1], shape[0]):
            return None, "boxes for a frame of another size"
        return boxes.boxes.astype(np.float64), ""

    def _adopt(self, attachment: Any) -> None:
        """Keep the settings a reply carries, when they are valid ones."""
        raw = attachment.to_bytes() if attachment is not None else b""
        if not raw or len(raw) > MAX_SETTINGS_BYTES:
            return
        try:
            settings = json.loads(raw)
            if settings != self._settings:
                self._local = HaarFaceDetector.from_settings(settings)
                self._settings = settings
        except (ValueError, RuntimeError, RecursionError) as exc:
            self.svc.reject("detector reply", f"detector settings refused: {exc}"[:200])

    @property
    def local_settings(self) -> dict[str, Any]:
        """The settings the local fall-back searches with."""
        return self._local_detector().settings()

    def _local_detector(self) -> HaarFaceDetector:
        if self._local is None:
            self._local = (HaarFaceDetector.from_settings(self._settings) if self._settings
                           else HaarFaceDetector())
        return self._local

    def _detect_locally(self, image: np.ndarray) -> np.ndarray:
        self.local_detections += 1
        return self._local_detector().detect(image)


def _err_text(reply: Any) -> str:
    try:
        return reply.err.payload.to_bytes().decode(errors="replace")[:200]
    except Exception:  # an error reply without a readable payload
        return "no reason given"
