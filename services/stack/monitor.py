"""What the launcher sees on the bus: results per frame, statuses, end of stream, the summary.

Frames and overlays are watched only when they are recorded (their producers' statuses
count them otherwise). Everything is screened like a service's input
(:class:`services.bus.inbox.Screen`): only messages of the run signed by the run's own
services count, each index once; everything else is ignored or rejected, counted by reason
in the summary, and the runs of statuses of another run are listed there. What it keeps per
frame is bounded by a window (:mod:`services.stack.tally`), however long the run.

When a service is restarted the monitor hands the new process the run's high-water marks
(:meth:`StackMonitor.restarting`) and closes the service's answers up to them: a frame its
predecessor missed stays unanswered whatever comes later.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from typing import Any

from proto import EndOfStream, Message, Status, decode
from proto.keys import status_wildcard
from services.bus.session import Service
from services.bus.trust import FLOORED, Floors, Replays
from services.stack.drain import EndOfRun
from services.stack.recorder import IMAGE_KINDS, RESULT_KINDS, RecordWriter
from services.stack.registry import SERVICES
from services.stack.tally import Pairs, Tally

RESULTS = ("fit", "pose", "expression")
COUNTS = ("frames_in", "frames_out", "dropped", "rejected", "lost", "ignored", "failed")
"""The status counts a summary adds up over a service's processes."""
LATENCIES = 20_000
"""Pose latencies kept for the summary's percentiles (the latest)."""
MAX_FOREIGN_RUNS = 16
"""Other runs whose statuses are listed in the summary (more are only counted ignored)."""


class StackMonitor:
    """Counts and records a run's messages, as the launcher's service receives them."""

    def __init__(self, svc: Service, recorder: RecordWriter | None, record_images: bool,
                 end: EndOfRun | None = None, expected: list[str] | None = None) -> None:
        self.svc = svc
        self.expected = list(expected or [])
        """The run's services (those of every host, across hosts)."""
        self.replays = Replays()
        self.recorder = recorder
        self.indices: dict[str, Tally] = {k: Tally() for k in RESULTS}
        """Frames answered, per kind of result (a frame "with" an expression has a label)."""
        self.highest: dict[tuple[str, str], int] = {}
        """(producer, kind) -> the highest frame index of the run seen."""
        self.counts: dict[str, int] = {k: 0 for k in (*RESULT_KINDS, *IMAGE_KINDS)}
        self.fits_failed = 0
        self.fits_no_face = 0
        self.statuses: dict[str, Status] = {}
        self.incarnations: dict[tuple[str, int], Status] = {}
        """The last status of each process a service has had (by its restart count)."""
        self.pairs = Pairs()
        """Each fit with landmarks is owed a pose."""
        self.foreign: dict[str, set[str]] = {}
        """Run id -> stack services of another run seen on the bus (from their statuses)."""
        self.eos: EndOfStream | None = None
        self.end = end or EndOfRun()
        """When the run's results are all in (:mod:`services.stack.drain`)."""
        self.pose_latency_ms: collections.deque[float] = collections.deque(maxlen=LATENCIES)
        self._lock = threading.Lock()
        self._record_images = record_images

    @property
    def watches_images(self) -> bool:
        """Whether the launcher takes the frames and overlays: only to record them. Else it
        counts them from their producers' statuses, and receives, checks and decodes none of
        the run's largest messages."""
        return self.recorder is not None and self._record_images

    def subscribe(self) -> None:
        for kind in (*RESULT_KINDS, *(IMAGE_KINDS if self.watches_images else ())):
            if kind == "status":
                continue
            self.svc.subscribe(self.svc.key(kind), self._on_sample)
        self.svc.subscribe(status_wildcard(self.svc.stream), self._on_sample)

    def _on_sample(self, sample: Any) -> None:
        key, payload = str(sample.key_expr), sample.payload.to_bytes()
        kind = key.rsplit("/", 2)[-2] if "/status/" in key else key.rsplit("/", 1)[-1]
        msg = self.svc.screen.check(payload, key, kind, self.replays)
        if msg is None:
            self._note_foreign(payload, kind)
            return
        if self.recorder is not None and (kind not in IMAGE_KINDS or self._record_images):
            self.recorder.write(payload)
        with self._lock:
            self._count(msg)

    def _note_foreign(self, payload: bytes, kind: str) -> None:
        if kind != "status":
            return
        try:
            status = decode(payload, "status")
        except ValueError:
            return
        if status.header.run_id != self.svc.run_id and status.service in SERVICES:
            with self._lock:
                if (status.header.run_id in self.foreign
                        or len(self.foreign) < MAX_FOREIGN_RUNS):
                    self.foreign.setdefault(status.header.run_id, set()).add(status.service)

    def _count(self, msg: Message) -> None:
        self.counts[msg.KIND] += 1
        self.end.saw(msg)
        h = msg.header
        if msg.KIND in FLOORED:
            stream = (h.producer, msg.KIND)
            self.highest[stream] = max(self.highest.get(stream, -1), h.frame_index)
        # A frame "with" an expression has a label; every fit gets an expression message.
        if msg.KIND in self.indices and (msg.KIND != "expression" or msg.label):
            self.indices[msg.KIND].add(h.frame_index)
        if msg.KIND == "fit":
            if len(msg.landmarks):
                self.pairs.fit((h.frame_index, msg.face_id))
            if msg.failed:
                self.fits_failed += 1
                self.fits_no_face += len(msg.landmarks) == 0
        elif msg.KIND == "pose":
            self.pairs.pose((h.frame_index, msg.face_id))
            self.pose_latency_ms.append((h.publish_time_ns - h.capture_time_ns) / 1e6)
        elif msg.KIND == "status":
            self.statuses[msg.service] = msg
            self.incarnations[(msg.service, msg.restarts)] = msg
        elif msg.KIND == "eos":
            self.eos = msg

    def restarting(self, name: str) -> Floors:
        """Service ``name`` is being restarted: the run's high-water marks for its new
        process, and its answers closed up to them (what its predecessor missed stays
        unanswered, whatever comes later)."""
        with self._lock:
            floors = dict(self.highest)
            for kind in SERVICES[name].publishes if name in SERVICES else ():
                upto = max((floors.get((p, k), -1) for p, k in floors
                            if k in SERVICES[name].reads), default=-1)
                if kind in self.indices:
                    self.indices[kind].close(upto)
                if kind == "pose":
                    self.pairs.close(upto)
        return floors

    def wait_for_final_statuses(self, services: list[str], timeout: float) -> list[str]:
        """Wait until each of ``services`` has sent its last status; return those missing."""
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                missing = [n for n in services if n not in self.statuses
                           or self.statuses[n].state not in ("stopped", "failed")]
            if not missing or time.monotonic() >= deadline:
                return missing
            time.sleep(0.02)

    def summary(self, exclude: str = "") -> dict[str, Any]:
        """Counts, end of stream, each service's last status and the frames lost, as plain data."""
        with self._lock:
            total = None if self.eos is None else self.eos.total_frames
            services = {n: self._service_dict(n) for n in sorted(self.statuses) if n != exclude}
            unanswered = self._unanswered(services, total)
            return {
                "total_frames": total,
                "eos_reason": None if self.eos is None else self.eos.reason,
                "frames_with": {k: v.count for k, v in self.indices.items()},
                "late": {k: v.late for k, v in self.indices.items()} | {
                    "pose": self.pairs.late},
                "messages": self._messages(services),
                "fits_failed": self.fits_failed,
                "fits_no_face": self.fits_no_face,
                "pose_latency_ms": _percentiles(sorted(self.pose_latency_ms)),
                "services": services,
                "unanswered": unanswered,
                "frames_lost": unanswered["fit"],
                "foreign_runs": {run: sorted(names) for run, names in self.foreign.items()},
                "ignored": dict(sorted(self.svc.stats.ignored_by.items())),
                "rejected": self.svc.stats.rejected,
            }

    def _messages(self, services: dict[str, Any]) -> dict[str, int]:
        """Messages of each kind seen; frames and overlays, unless watched, as their
        producers counted them."""
        counts = dict(self.counts)
        if not self.watches_images:
            for kind, producer in (("frame", "source"), ("overlay", "ar")):
                counts[kind] = services.get(producer, {}).get("frames_out", 0)
        return counts

    def _service_dict(self, name: str) -> dict[str, Any]:
        """A service's last status, its counts summed over every process it has had (a
        restarted service counts from zero again)."""
        out = _status_dict(self.statuses[name])
        mine = [s for (n, _), s in self.incarnations.items() if n == name]
        for count in COUNTS:
            out[count] = sum(getattr(s, count) for s in mine)
        return out

    def _unanswered(self, services: dict[str, Any], total: int | None) -> dict[str, int]:
        """Frames of the run without a fit, and fits with landmarks without a pose, that no
        service dropped by design (rejected, lost on the way, failed, or never taken)."""
        def owed(expected: int, answered: int, service: str) -> int:
            dropped = services.get(service, {}).get("dropped", 0)
            return max(0, expected - answered - dropped)

        fits = owed(total, self.indices["fit"].count, "fitter") if total is not None else 0
        poses = 0
        if "pose" in services:
            poses = owed(self.pairs.with_face, self.pairs.posed, "pose")
        return {"fit": fits, "pose": poses}


def _percentiles(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"p50": None, "p99": None}
    import numpy as np

    p50, p99 = np.percentile(values, [50, 99])
    return {"p50": float(p50), "p99": float(p99)}


def _status_dict(s: Status) -> dict[str, Any]:
    def num(x: float) -> float | None:
        return None if math.isnan(x) else round(x, 3)

    return {"state": s.state, "frames_in": s.frames_in, "frames_out": s.frames_out,
            "dropped": s.dropped, "rejected": s.rejected, "lost": s.lost, "ignored": s.ignored,
            "failed": s.failed,
            "latency_p50_ms": num(s.latency_p50_ms), "latency_p99_ms": num(s.latency_p99_ms),
            "restarts": s.restarts, "message": s.message}


def summary_table(summary: dict[str, Any]) -> str:
    """The summary as a few lines of text."""
    end = (f"end of stream: {summary['total_frames']} frames ({summary['eos_reason']})"
           if summary["total_frames"] is not None else "no end of stream (stopped before it)")
    lines = [f"{end}; "
             f"frames with a fit {summary['frames_with']['fit']}, pose "
             f"{summary['frames_with']['pose']}, expression "
             f"{summary['frames_with']['expression']}; failed fits {summary['fits_failed']} "
             f"(no face {summary['fits_no_face']}); overlays {summary['messages']['overlay']}; "
             f"unanswered: {summary['unanswered']['fit']} frames without a fit, "
             f"{summary['unanswered']['pose']} fits with a face without a pose",
             f"{'service':<12} {'state':<9} {'in':>6} {'out':>6} {'dropped':>7} {'rejected':>8} "
             f"{'lost':>5} {'ignored':>7} {'failed':>6} {'p50 ms':>7} {'p99 ms':>7} "
             f"{'restarts':>8}"]
    for name, s in summary["services"].items():
        p50 = "-" if s["latency_p50_ms"] is None else f"{s['latency_p50_ms']:.1f}"
        p99 = "-" if s["latency_p99_ms"] is None else f"{s['latency_p99_ms']:.1f}"
        lines.append(f"{name:<12} {s['state']:<9} {s['frames_in']:>6} {s['frames_out']:>6} "
                     f"{s['dropped']:>7} {s['rejected']:>8} {s['lost']:>5} {s['ignored']:>7} "
                     f"{s['failed']:>6} {p50:>7} {p99:>7} {s['restarts']:>8}")
    for name in ("source", "ar"):  # how frames travelled; what the renderer drew
        if name in summary["services"]:
            lines.append(f"{name}: {summary['services'][name]['message']}")
    ignored = summary.get("ignored", {})
    if ignored or summary.get("rejected"):
        parts = [f"{n} {why}" for why, n in ignored.items()]
        if summary.get("rejected"):
            parts.append(f"{summary['rejected']} malformed (rejected)")
        lines.append(f"not the run's, seen by the launcher and ignored: {', '.join(parts)}")
    for run, names in summary.get("foreign_runs", {}).items():
        lines.append(f"ignored: services of another run {run!r} on this bus: {', '.join(names)}")
    return "\n".join(lines)
