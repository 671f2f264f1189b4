"""Everything the launcher can check before it starts a process.

Each check raises :class:`PreflightError` with one line naming the option
and the problem, so that ``aamtrack run`` exits 2 within a second or two
instead of starting the stack and failing later:

- every service's command line, parsed by that service's own parser;
- the input: a video is opened and its frame size checked against the
  frame limit;
- the fitting model (loaded once), the expression classifier (loaded and
  matched to the model) and the camera calibration (read and checked);
- the endpoint the launcher listens on (free, or given in a form Zenoh reads);
- the Rerun viewer the recording streams to (``--connect``): it must answer;
- every file the run writes (``--rrd``, ``--record``, ``--summary``): a file that can be
  created where it is asked for (:func:`check_output`, which the other commands use too).
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import re
import socket
from dataclasses import replace
from pathlib import Path
from typing import Any

from services.bus.args import parse_service_args, service_argv
from services.bus.connection import BusOptions
from services.stack.options import StackOptions
from services.stack.registry import SERVICES

log = logging.getLogger("aamtrack.launcher")

ENDPOINT = re.compile(r"tcp/(?P<host>[0-9A-Za-z.\-\[\]:]+):(?P<port>\d+)")


class PreflightError(ValueError):
    """A run cannot start; the message is one line naming the option and the problem."""


def check_service_args(opts: StackOptions, bus: BusOptions) -> None:
    """Parse each service's full command line (with ``--set`` extras) by its own parser."""
    for name, options in opts.services.items():
        argv = service_argv(bus, options) + opts.extra.get(name, [])
        info = SERVICES[name]
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err):
                parse_service_args(name, info.summary, info.options, argv)
        except SystemExit:
            lines = [line for line in err.getvalue().splitlines() if "error:" in line]
            problem = lines[-1].split("error:", 1)[1].strip() if lines else "invalid arguments"
            raise PreflightError(f"{name}: {problem}") from None


def check_input(opts: StackOptions) -> None:
    """Open a video file or a camera once (a stream URL is opened by the source, which waits
    for it)."""
    source = opts.services.get("source")
    if source is None or (source.video is None and source.camera is None):
        return
    from services.source.capture import InputSpec, SourceError, VideoInput

    option = "--video" if source.video is not None else "--camera"
    try:
        VideoInput(InputSpec.of(source)).close()
    except SourceError as exc:
        raise PreflightError(f"{option}: {exc}") from None


def check_output(option: str, path: str | os.PathLike[str]) -> None:
    """A file can be written at ``path``: not a folder, in a folder that exists, creatable
    (tried: a place such as ``/proc`` refuses only then); a file made for the try is removed.

    Raises
    ------
    PreflightError
        Naming ``option`` and the problem.
    """
    target = Path(path)
    if target.is_dir():
        raise PreflightError(f"{option} {target}: is a folder; give a file name")
    if not target.parent.is_dir():
        raise PreflightError(f"{option} {target}: the folder {target.parent} does not exist")
    existed = target.exists()
    try:
        with open(target, "ab"):
            pass
    except OSError as exc:
        raise PreflightError(f"{option} {target}: cannot be written ({exc.strerror})") from None
    if not existed:
        target.unlink(missing_ok=True)


def check_outputs(opts: StackOptions) -> None:
    """Every file the run is asked to write."""
    rerun = opts.services.get("rerun")
    for option, path in (("--record", opts.launch.record), ("--summary", opts.launch.summary),
                         ("--rrd", getattr(rerun, "rrd", None))):
        if path:
            check_output(option, path)


def check_models(opts: StackOptions) -> None:
    """Load the fitting model, the classifier and the calibration the services are given."""
    from aamcore.fitting.model import FittingModel
    from aamcore.model.file import ModelFileError

    fitter = opts.services.get("fitter")
    if fitter is not None and fitter.model.file:
        from aamcore.fitting.algorithm import missing_part

        try:
            model = FittingModel.load(fitter.model.file)
        except ModelFileError as exc:
            raise PreflightError(f"--model: {exc}") from None
        why = missing_part(model, fitter.algorithm)
        if why:
            raise PreflightError(f"--model {fitter.model.file}: {why}")
    check_classifier(opts.services.get("expression"), fitter)
    pose = opts.services.get("pose")
    if pose is not None:
        from aamcore.pose import IntrinsicsError, PoseError
        from aamcore.pose.estimator import Cameras, HeadPoseEstimator

        try:
            cameras = Cameras(pose.pose.fov, pose.pose.calibration)
        except (IntrinsicsError, OSError, ValueError) as exc:
            raise PreflightError(f"--calibration: {exc}") from None
        try:  # its head model comes from the data folder
            HeadPoseEstimator(cameras, method=pose.pose.estimator)
        except (PoseError, OSError, ValueError) as exc:
            raise PreflightError(f"pose: {exc}") from None


def check_classifier(expression: Any, fitter: Any) -> None:
    """The classifier loads and was made for the fits of the fitter's model and algorithm."""
    if expression is None or not expression.expression.classifier:
        return
    from aamcore.expression import AAMMismatchError, ClassifierFileError
    from aamcore.operators.expression import load_classifier

    model = expression.fitting_model or (fitter.model.file if fitter is not None else None)
    try:
        load_classifier(expression.expression.classifier, model,
                        fitter.algorithm if fitter is not None else None)
    except (ClassifierFileError, AAMMismatchError, OSError) as exc:
        raise PreflightError(f"--classifier: {exc}") from None


def check_endpoint(endpoint: str, explicit: bool) -> None:
    """An endpoint the launcher can listen on: ``tcp/HOST:PORT`` with the port free, or
    ``unixsock-stream/PATH`` in an existing folder with nobody on it."""
    from services.bus.runtime import in_use, socket_path

    path = socket_path(endpoint)
    if path is not None:
        if not path.parent.is_dir():
            raise PreflightError(f"--endpoint {endpoint}: the folder {path.parent} does not "
                                 "exist")
        if in_use(path):
            raise PreflightError(f"--endpoint {endpoint}: in use (another run of the stack?)")
        return
    match = ENDPOINT.fullmatch(endpoint)
    if match is None:
        raise PreflightError(f"--endpoint {endpoint!r}: expected tcp/HOST:PORT, e.g. "
                             "tcp/127.0.0.1:7447, or unixsock-stream/PATH")
    host, port = match["host"].strip("[]"), int(match["port"])
    if not 1 <= port <= 65535:
        raise PreflightError(f"--endpoint {endpoint}: port {port} is outside 1 to 65535")
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError as exc:
            why = "in use (another run of the stack?)" if explicit else exc.strerror
            raise PreflightError(f"--endpoint {endpoint}: cannot listen there: {why}") from None


def check_viewer(opts: StackOptions) -> None:
    """The running Rerun viewer the rerun service is to stream to answers on its port."""
    rerun = opts.services.get("rerun")
    viewer = getattr(rerun, "viewer", None)
    if viewer is None:
        return
    from services.rerun_logger.viewer import ViewerError
    from services.rerun_logger.viewer import check_viewer as probe

    try:
        probe(viewer)
    except ViewerError as exc:
        raise PreflightError(f"--connect: {exc}") from None


def prepare_models(opts: StackOptions) -> StackOptions:
    """The run with every model the services need named: trained or found in the cache.

    The fitter's model is ``--model`` or the default one; the expression
    service gets the same model and its classifier (``--classifier`` or the
    cached one for the fitter's model, algorithm and the deployed features,
    trained on first use; none when JAFFE cannot be had, and the service then
    says why in its status).
    """
    from aamcore.io.sample import DatasetError
    from aamcore.profiles import classifier_path, model_path
    from services.stack.options import pipeline

    services = dict(opts.services)
    fitter = services.get("fitter")
    if fitter is None:
        return opts
    path = str(model_path(fitter.model))
    services["fitter"] = fitter.with_values(model_file=path)
    expression = services.get("expression")
    if expression is not None:
        classifier = expression.expression.classifier
        if not classifier:
            try:
                classifier = str(classifier_path(path, pipeline(opts)))
            except (DatasetError, OSError, ValueError) as exc:
                log.warning("no expression classifier: %s", exc)
        services["expression"] = expression.with_values(
            fitting_model=path, expression_classifier=classifier, algorithm=fitter.algorithm)
    return replace(opts, services=services)
