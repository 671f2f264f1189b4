"""The services of the stack: their names, modules and options, in pipeline order."""

from __future__ import annotations

from dataclasses import dataclass

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
    """One service: the module whose ``main(argv)`` runs it and its options class."""

    name: str
    module: str
    options: type[Options]
    summary: str


SERVICES: dict[str, ServiceInfo] = {
    s.name: s
    for s in (
        ServiceInfo("source", "services.source.service", SourceOptions,
                    "frames of a video file, camera or stream URL"),
        ServiceInfo("detector", "services.detector.service", DetectorOptions,
                    "Haar face detection on request"),
        ServiceInfo("fitter", "services.fitter.service", FitterOptions,
                    "landmarks: the AAM tracked from frame to frame"),
        ServiceInfo("pose", "services.pose.service", PoseOptions, "head pose of each fit"),
        ServiceInfo("expression", "services.expression.service", ExpressionOptions,
                    "facial expression of each fit, from the fit and its frame"),
        ServiceInfo("ar", "services.ar.service", AROptions, "3D glasses drawn at each pose"),
        ServiceInfo("rerun", "services.rerun_logger.service", RerunOptions,
                    "everything into a Rerun recording or viewer"),
    )
}
"""Service name -> :class:`ServiceInfo`, in pipeline order."""
