"""The services of the stack and the dataflow between them, declared once.

Each service names the kinds it reads and publishes (``status`` aside: every service
publishes its own, and the launcher, the recorder and the Rerun logger read them); the
end-of-run rule, the recorder, the monitor and the Rerun logger's inputs are derived from
it, and a test checks that every kind published has a reader and every kind read a
producer.
"""

from __future__ import annotations

from dataclasses import dataclass

from proto.keys import DETECT
from services.ar.options import AROptions
from services.bus.options import Options
from services.detector.options import DetectorOptions
from services.expression.options import ExpressionOptions
from services.fitter.options import FitterOptions
from services.pose.options import PoseOptions
from services.rerun_logger.options import RerunOptions
from services.source.options import SourceOptions


@dataclass(frozen=True)
class ServiceInfo:
    """One service: the module whose ``main(argv)`` runs it, its options class, and the
    kinds it reads (``asks``: the queryables it queries) and publishes."""

    name: str
    module: str
    options: type[Options]
    summary: str
    reads: tuple[str, ...] = ()
    publishes: tuple[str, ...] = ()
    asks: tuple[str, ...] = ()
    answers: tuple[str, ...] = ()


SERVICES: dict[str, ServiceInfo] = {
    s.name: s
    for s in (
        ServiceInfo("source", "services.source.service", SourceOptions,
                    "frames of a video file, camera or stream URL",
                    reads=("fit",), publishes=("frame", "eos")),  # fits: fast pacing
        ServiceInfo("detector", "services.detector.service", DetectorOptions,
                    "Haar face detection on request", publishes=("boxes",),
                    answers=(DETECT,)),
        ServiceInfo("fitter", "services.fitter.service", FitterOptions,
                    "landmarks: the AAM tracked from frame to frame", reads=("frame",),
                    publishes=("fit",), asks=(DETECT,)),
        ServiceInfo("pose", "services.pose.service", PoseOptions, "head pose of each fit",
                    reads=("fit",), publishes=("pose",)),
        ServiceInfo("expression", "services.expression.service", ExpressionOptions,
                    "facial expression of each fit, from the fit and its frame",
                    reads=("fit", "frame"), publishes=("expression",)),
        ServiceInfo("ar", "services.ar.service", AROptions, "3D glasses drawn at each pose",
                    reads=("pose", "frame"), publishes=("overlay",)),
        ServiceInfo("rerun", "services.rerun_logger.service", RerunOptions,
                    "everything into a Rerun recording or viewer",
                    reads=("eos", "boxes", "fit", "pose", "expression", "frame", "overlay")),
    )
}
"""Service name -> :class:`ServiceInfo`, in pipeline order."""

ANSWERS = tuple(kind for s in SERVICES.values() if s.name != "source" for kind in s.publishes
                if kind != "boxes")
"""What the stages publish in answer to a frame, beyond the detector's boxes: while any of
it still comes, a run that reached its end of stream is not over (:mod:`.drain`)."""


def readers(kind: str) -> list[str]:
    """The services that read ``kind``."""
    return [s.name for s in SERVICES.values() if kind in s.reads]


def producers(kind: str) -> list[str]:
    """The services that publish ``kind``."""
    return [s.name for s in SERVICES.values() if kind in s.publishes]
