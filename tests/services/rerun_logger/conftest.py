"""Fixtures of the Rerun logger tests: real faces as messages, reading ``.rrd`` files back,
and real Rerun gRPC servers (viewers without a window) that save what they receive."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
import warnings
from collections import defaultdict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pyarrow as pa
import pytest
import rerun as rr
import rerun_cli
from rerun.chunk import RrdReader
from scipy.spatial.transform import Rotation

from aamcore.io import FaceSample, load_annotated_folder
from aamcore.pose.head_model import openface68
from proto.header import Header
from proto.messages import (
    Expression,
    FaceBoxes,
    Fit,
    FitAppearance,
    Frame,
    HeadPose,
    Message,
    Overlay,
)
from services.rerun_logger.recording import Recording, open_recording

CAPTURE_NS = 1_750_000_000_000_000_000
FRAME_NS = 33_333_333
CLASSES = ("neutral", "happy", "sad", "surprise", "anger", "disgust", "fear")
RERUN_CLI = Path(sys.executable).with_name("rerun")
RERUN_BINARY = Path(rerun_cli.__file__).with_name("rerun")
"""The CLI's executable itself (``RERUN_CLI`` is a Python wrapper that runs it as a child)."""


@dataclass
class RrdContent:
    """What a recording holds, read back with ``rerun.chunk.RrdReader``.

    Attributes
    ----------
    rows : dict
        Entity path (with a leading ``/``) -> list of rows, each a dict of
        column name -> value; ``frame`` is the frame index (absent for static rows),
        ``static`` whether the row is static.
    blueprint_rows : list of dict
        Rows of the blueprint store, each with its ``entity``.
    """

    rows: dict[str, list[dict[str, Any]]] = field(default_factory=lambda: defaultdict(list))
    blueprint_rows: list[dict[str, Any]] = field(default_factory=list)

    @property
    def entities(self) -> set[str]:
        return set(self.rows)

    def values(self, entity: str, column: str) -> list[Any]:
        """Temporal values of ``column`` on ``entity`` in frame order."""
        rows = [r for r in self.rows[entity] if not r["static"] and column in r]
        return [r[column] for r in sorted(rows, key=lambda r: r["frame"])]

    def mono(self, entity: str, column: str) -> list[Any]:
        """Like :meth:`values` for a column of one value per row (e.g. ``Scalars:scalars``)."""
        values = self.values(entity, column)
        assert all(isinstance(v, list) and len(v) == 1 for v in values), values
        return [v[0] for v in values]

    def frames(self, entity: str, column: str) -> list[int]:
        """Frame indices at which ``column`` was logged on ``entity``, in order."""
        rows = [r for r in self.rows[entity] if not r["static"] and column in r]
        return sorted(r["frame"] for r in rows)

    def static(self, entity: str, column: str) -> Any:
        """The static value of ``column`` on ``entity`` (the last one logged)."""
        found = [r[column] for r in self.rows[entity] if r["static"] and column in r]
        assert found, f"no static {column} on {entity}"
        return found[-1]


def _batch_rows(batch: pa.RecordBatch, static: bool) -> list[dict[str, Any]]:
    columns = {}
    for name in batch.schema.names:
        if name.startswith("rerun.controls") or name == "log_time":
            continue
        col = batch.column(name)
        if pa.types.is_timestamp(col.type):
            col = col.cast(pa.int64())
        columns[name] = col.to_pylist()
    rows = []
    for i in range(batch.num_rows):
        row = {name: values[i] for name, values in columns.items() if values[i] is not None}
        row["static"] = static
        rows.append(row)
    return rows


def read_rrd(path: Path) -> RrdContent:
    """Read every chunk of the recording (and its blueprint) in ``path``."""
    reader = RrdReader(path)
    content = RrdContent()
    for chunk in reader.stream():
        rows = _batch_rows(chunk.to_record_batch(), chunk.is_static)
        content.rows[chunk.entity_path].extend(rows)
    for store in reader.blueprints():
        for chunk in reader.stream(store=store):
            for row in _batch_rows(chunk.to_record_batch(), chunk.is_static):
                content.blueprint_rows.append(row | {"entity": chunk.entity_path})
    return content


def verify_rrd(path: Path) -> str:
    """Run ``rerun rrd verify`` on ``path``; fail the test unless it passes."""
    done = subprocess.run([str(RERUN_CLI), "rrd", "verify", str(path)],
                          capture_output=True, text=True, timeout=60)  # footers checked too
    assert done.returncode == 0, f"rerun rrd verify failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout + done.stderr


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_until(condition: Callable[[], Any], what: str, timeout: float = 30.0) -> Any:
    """Poll ``condition`` until it returns something true; fail after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not (value := condition()):
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)
    return value


def port_listens(port: int) -> bool:
    """Whether something accepts TCP connections on 127.0.0.1:``port``."""
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.5):
            return True
    except OSError:
        return False


class RerunServer:
    """A real Rerun gRPC server, as a viewer runs one, saving every message it gets to a file.

    ``rerun --save FILE --bind 127.0.0.1 --port PORT`` listens for SDKs on
    ``url`` and writes what they send as it comes (a file without footer,
    readable as a stream); with ``source``, it pulls from another server
    instead, as a viewer connecting to it would.
    """

    def __init__(self, save: Path, source: str | None = None) -> None:
        self.save = save
        self.port = free_port()
        self.url = f"rerun+http://127.0.0.1:{self.port}/proxy"
        argv = [str(RERUN_BINARY), "--save", str(save), "--bind", "127.0.0.1",
                "--port", str(self.port), *([source] if source else [])]
        self.process = subprocess.Popen(argv, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.PIPE, text=True)
        wait_until(lambda: port_listens(self.port) or self.process.poll() is not None,
                   "the Rerun server to listen")
        assert self.process.poll() is None, f"rerun server exited: {self.process.stderr.read()}"

    def received(self) -> RrdContent | None:
        """What the server has written so far, or None while it cannot be read yet."""
        if not self.save.is_file():
            return None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # no footer: the server is still writing
                return read_rrd(self.save)
        except Exception:  # a message half written: read again later
            return None

    def wait_for(self, condition: Callable[[RrdContent], bool], what: str,
                 timeout: float = 30.0) -> RrdContent:
        """What the server saved, once it satisfies ``condition``."""
        def ready() -> RrdContent | None:
            got = self.received()
            return got if got is not None and condition(got) else None

        return wait_until(ready, what, timeout)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5)
        if self.process.stderr is not None:
            self.process.stderr.close()


@pytest.fixture
def rerun_server(tmp_path: Path) -> Iterator[Callable[..., RerunServer]]:
    """``rerun_server(name="viewer", source=None)``: a started :class:`RerunServer`
    saving to ``tmp_path / f"{name}.rrd"``; stopped after the test."""
    started: list[RerunServer] = []

    def make(name: str = "viewer", source: str | None = None) -> RerunServer:
        started.append(RerunServer(tmp_path / f"{name}.rrd", source))
        return started[-1]

    yield make
    for server in started:
        server.stop()


def has_event(text: str) -> Callable[[RrdContent], bool]:
    """A condition: the recording holds an event whose text contains ``text``."""
    def check(content: RrdContent) -> bool:
        rows = content.rows.get("/events", [])
        return any(text in t for r in rows for t in r.get("TextLog:text", []))

    return check


@pytest.fixture(autouse=True, scope="session")
def _strict_rerun() -> None:
    """Make Rerun raise on a bad log call instead of only warning."""
    rr.set_strict_mode(True)


@pytest.fixture
def new_recording(tmp_path: Path) -> Iterator[Callable[[str], Recording]]:
    """``new_recording(name)``: a recording to ``tmp_path / name`` (close it before reading)."""
    opened: list[Recording] = []

    def make(name: str = "test.rrd") -> Recording:
        opened.append(open_recording(tmp_path / name))
        return opened[-1]

    yield make
    for rec in opened:
        rec.close()


@pytest.fixture(scope="session")
def rrd_tools() -> tuple[Callable[[Path], RrdContent], Callable[[Path], str]]:
    """``(read_rrd, verify_rrd)``."""
    assert RERUN_CLI.is_file(), f"the rerun CLI is not installed beside {sys.executable}"
    return read_rrd, verify_rrd


@pytest.fixture(scope="session")
def faces(lfpw_dir: Path) -> list[FaceSample]:
    """Three real LFPW faces (68 iBUG landmarks each) with their images."""
    samples = load_annotated_folder(lfpw_dir, limit=3).samples
    assert len(samples) == 3 and all(len(s.points) == 68 for s in samples)
    return samples


def header(producer: str, index: int, latency_ms: float = 0.0) -> Header:
    """Header of stream ``cam0`` for frame ``index``, published ``latency_ms`` after capture."""
    capture = CAPTURE_NS + index * FRAME_NS
    return Header("cam0", index, capture, producer, capture + int(latency_ms * 1e6))


def intrinsics(width: int, height: int, fov_deg: float = 60.0) -> np.ndarray:
    """A pinhole camera matrix ``(3, 3)`` with the given horizontal field of view."""
    f = 0.5 * width / np.tan(np.radians(fov_deg) / 2)
    return np.array([[f, 0.0, width / 2], [0.0, f, height / 2], [0.0, 0.0, 1.0]])


def pose_of(points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Head pose ``(R (3, 3), T (3,))`` of 68 landmarks ``(68, 2)`` by OpenCV's SQPnP."""
    model = openface68().points
    ok, rvec, tvec = cv2.solvePnP(
        model, points.astype(np.float64), intrinsics(width, height), None,
        flags=cv2.SOLVEPNP_SQPNP,
    )
    assert ok
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


def face_messages(sample: FaceSample, index: int, failed: bool = False) -> list[Message]:
    """Every per-frame message for one real face, as the stack would publish them.

    The frame is raw BGR, the overlay JPEG; the box is the landmarks' bounding
    box; the pose is SQPnP of the landmarks with the OpenFace mean face; the
    expression scores are a softmax of fixed logits shifted by the frame index.
    """
    image = sample.load_image()
    height, width = image.shape[:2]
    points = sample.points
    lo, hi = points.min(axis=0), points.max(axis=0)
    R, T = pose_of(points, width, height)
    roll, pitch, yaw = Rotation.from_matrix(R).as_euler("zxy", degrees=True)
    logits = np.arange(len(CLASSES), dtype=float) * 0.3 + np.roll(np.eye(len(CLASSES))[0], index)
    scores = np.exp(logits) / np.exp(logits).sum()
    ok, jpeg = cv2.imencode(".jpg", cv2.flip(image, 1))
    assert ok
    return [
        Frame.from_array(header("source", index, 1.0), image),
        FaceBoxes(header("detector", index, 20.0), image_width=width, image_height=height,
                  boxes=np.array([[*lo, *(hi - lo)]]), scores=np.array([0.9])),
        Fit(header("fitter", index, 30.0 + index), scheme="ibug68", landmarks=points,
            similarity=np.array([1.0, 0.0, 0.0, 0.0]), image_width=width, image_height=height,
            failed=failed, failure_reason="texture error too large" if failed else "",
            confidence=0.0 if failed else 0.8, warp_path="cpu",
            appearance=FitAppearance(np.zeros(5), np.full((6, 8), 0.25 * index),
                                     0.01 * (index + 1), 5 + index, not failed,
                                     (np.arange(len(points)) < 10 * index).astype(np.uint8))),
        HeadPose(header("pose", index, 32.0 + index), rotation=R, translation_mm=T,
                 roll_deg=roll, pitch_deg=pitch, yaw_deg=yaw,
                 intrinsics=intrinsics(width, height), image_width=width, image_height=height,
                 intrinsics_source="assumed:fov60", iterations=1, reliable=True, reason="",
                 angle_sd_deg=0.5),
        Expression(header("expression", index, 35.0 + index), label=CLASSES[int(np.argmax(scores))],
                   class_names=CLASSES, scores=scores, smoothed=False, reason=""),
        Overlay.from_jpeg(header("ar", index, 50.0 + index), jpeg.tobytes(), width, height),
    ]


@pytest.fixture(scope="session")
def messages_of() -> Callable[..., list[Message]]:
    """:func:`face_messages`."""
    return face_messages
