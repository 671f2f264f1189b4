"""``aamtrack run``: the whole stack on one host, from a video to end of stream.

The launcher

1. checks everything it can before any process starts (:mod:`services.stack.preflight`)
   and trains (or finds in the cache) the models the services need, so that
   no service trains while the video plays;
2. opens its own Zenoh session in peer mode listening on the endpoint: by
   default a Unix socket in the user's private folder (``<stream>.sock``, or
   one of the run's own while another run holds it; :mod:`services.bus.runtime`),
   so that no other user can reach the run; every service connects to it and
   listens on a socket (with ``--endpoint tcp/...``, a loopback port) of its
   own, and Zenoh's gossip joins them into a mesh (no router, multicast
   scouting off);
3. makes itself non-dumpable, then gives the run a run id and a key pair per service and
   one of its own (:mod:`proto.auth`; across hosts, the keys file the stack file names),
   each private key handed to its process only once that process is non-dumpable and
   untraced (:mod:`services.bus.handover`): every service signs what it publishes and
   accepts only messages of the run signed by their producer, each index once, so
   processes of another run or another program on the same bus change nothing (they are
   counted by reason in the summary); it answers ``aamtrack/<stream>/keys`` with the run's
   public keys signed by its own, whose fingerprint it prints, so that any reader can
   check every message;
4. starts each service as its own process (a fresh interpreter in a process group of its own, see
   :mod:`services.stack.supervisor`; each dies with the launcher), the
   source last, once the others hold their liveliness tokens;
5. watches the results and the services' status, restarting a service that
   dies; after end of stream it waits until the last frame's results are in
   and the bus has gone quiet;
   when the Rerun service serves the recording (``--serve PORT``), it leaves
   the stack running after that, says so on stdout and waits for Ctrl-C
   (or for that service to stop), so that viewers can still connect;
6. stops every process (SIGTERM, then SIGKILL after a timeout), prints a
   summary and returns 0, or non-zero with a message when the input failed,
   frames were lost, a service could not be kept running, or it was interrupted.
"""

from __future__ import annotations

import json
import logging
import os
import socket
import sys
import time
import uuid
from pathlib import Path
from typing import Any

from proto.auth import LAUNCHER, Keyring, keys_document
from proto.keys import keys_key
from services.bus.args import service_argv
from services.bus.connection import BusOptions
from services.bus.handover import HandoverError
from services.bus.options import OptionError
from services.bus.process import ENV_LOG_LEVEL
from services.bus.runtime import (
    in_use,
    remove_socket,
    runtime_dir,
    socket_endpoint,
    socket_path,
)
from services.bus.session import Service
from services.stack import preflight
from services.stack.drain import EndOfRun
from services.stack.hosts import deployment_keys, never_joined, not_joined, secure_launcher
from services.stack.monitor import StackMonitor, summary_table
from services.stack.options import StackOptions
from services.stack.outcome import (
    EXIT_FAILED,
    EXIT_INPUT,
    exit_code,
    output_problem,
    say_unwritten,
)
from services.stack.progress import run_progress
from services.stack.recorder import RecordWriter
from services.stack.registry import SERVICES
from services.stack.supervisor import ServiceSpec, Supervisor

log = logging.getLogger("aamtrack.launcher")
NAME = LAUNCHER
FINAL_STATUS_WAIT = 2.0
"""Seconds to wait, once the processes are gone, for their last status messages."""
BEST_EFFORT = {"ar": 5, "rerun": 5}
"""Niceness of the stages off the capture-to-pose path: they yield the CPU to it."""
JOIN_MARGIN = 10.0
"""Across hosts, seconds the source waits for the other hosts beyond the launcher's start
timeout, so that the launcher, not the source, says which host never joined."""
SERVICE_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "MALLOC_ARENA_MAX": "2"}
"""One compute thread per service process: many processes share few cores; two malloc
arenas, so that frame-sized buffers freed by Zenoh's threads are reused rather than
fragmenting one arena per thread (a service's memory stays flat over a long run)."""


def default_endpoint(stream: str, run_id: str) -> str:
    """The stream's Unix socket in the user's private folder (:mod:`services.bus.runtime`),
    or one of the run's own there while another run holds the stream's."""
    folder = runtime_dir()
    path = folder / f"{stream}.sock"
    return socket_endpoint(path if not in_use(path) else folder / f"{stream}-{run_id}.sock")


def service_listen(endpoint: str, run_id: str, name: str) -> str:
    """Where service ``name`` listens: a Unix socket of its own beside a launcher on one, else
    a free loopback port."""
    path = socket_path(endpoint)
    if path is None:
        return "tcp/127.0.0.1:0"
    return socket_endpoint(path.parent / f"{run_id}-{name}.sock")


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def service_specs(opts: StackOptions, bus: BusOptions, keyring: Keyring | None = None
                  ) -> list[ServiceSpec]:
    """The processes of the stack, the source last (waiting for the others). On one host
    each listens where :func:`service_listen` says; across hosts, as ``bus`` says. Each
    gets its own private key from ``keyring`` and every public key."""
    keyring = keyring or Keyring()
    names = [n for n in opts.services if n != "source"]
    specs = []
    for name in [*names, "source"] if "source" in opts.services else names:
        options = opts.services[name]
        if name == "source":
            wait_for = opts.wait_for if opts.wait_for is not None else tuple(names)
            # Across hosts the launcher says which host never joined, before the source gives up.
            timeout = opts.launch.start_timeout + (JOIN_MARGIN if opts.elsewhere else 0.0)
            options = options.replace(wait_for=wait_for, wait_timeout=timeout)
        own = bus if opts.bus is not None else bus.replace(
            listen=(service_listen(bus.connect[0], bus.run_id, name),))
        argv = service_argv(own, options, opts.verbose) + opts.extra.get(name, [])
        keys = keyring.for_service(name) if keyring else Keyring()
        specs.append(ServiceSpec(name, SERVICES[name].module, argv,
                                 restart=opts.launch.restart and name != "source",
                                 nice=BEST_EFFORT.get(name, 0), keyring=keys))
    return specs


def wait_for_end(svc: Service, sup: Supervisor, mon: StackMonitor, opts: StackOptions) -> str:
    """Watch the run until it is over; return why: ``done``, ``source failed``, ``stopped``,
    ``host H never joined``..."""
    said_eos = False
    joined = not opts.elsewhere
    deadline = time.monotonic() + opts.launch.start_timeout
    while not svc.wait(0.1):
        try:
            sup.check()
        except HandoverError as exc:  # a restarted service could not be given its key
            return f"refused: {exc}"
        if not joined:
            missing = not_joined(set(mon.statuses), opts)
            joined = not missing
            if missing and time.monotonic() >= deadline:
                return never_joined(missing, opts)
        if mon.eos is not None:
            if not said_eos:
                said_eos = True
                log.debug("end of stream after %d frames (%s)", mon.eos.total_frames,
                          mon.eos.reason)
            if mon.end.over():
                return "done"
        elif ("source" in opts.services and sup.exitcode("source") is not None
              and (svc.wait(1.0) or mon.eos is None)):
            return "source failed"  # it ended and, a second later, no end of stream came
        if sup.failed():
            return f"{', '.join(sup.failed())} could not be kept running"
        if problem := output_problem(mon):
            return problem
    return "stopped"



def serve_until_stopped(svc: Service, sup: Supervisor, port: int) -> str:
    """After the end of stream, while the rerun service serves on ``port``: wait for a stop
    (Ctrl-C) or for that service to end; the outcome stays ``done``."""
    url = f"rerun+http://127.0.0.1:{port}/proxy"
    print(f"aamtrack run: end of stream; the recording is served at {url} (view it with "
          f"`rerun --connect {url}`); Ctrl-C to stop", flush=True)
    while not svc.wait(0.2):
        sup.check()
        if sup.exitcode("rerun") == 0 or "rerun" in sup.failed():
            break
    return "done"


class Stack:
    """The stack's processes and the launcher's view of the bus.

    Use it as a context manager: entering opens the launcher's session and
    starts every service; :meth:`wait` watches the run until it ends; leaving
    stops every process and closes the session. :attr:`supervisor` and
    :attr:`monitor` are there for the caller to inspect (or to kill a
    service in a test).

    Parameters
    ----------
    opts : StackOptions
        With the models named (see :func:`preflight.prepare_models`).
    """

    def __init__(self, opts: StackOptions) -> None:
        self.opts = opts
        self.insecure = secure_launcher(opts.launch.insecure)
        """Why this launcher cannot keep its keys from other processes ("" when it can)."""
        stream = opts.launch.stream
        if opts.bus is None:
            self.run_id = f"run-{uuid.uuid4().hex[:12]}"
            try:
                self.endpoint = opts.launch.endpoint or default_endpoint(stream, self.run_id)
            except OptionError as exc:
                raise preflight.PreflightError(str(exc)) from None
            self.keyring = Keyring.generate([*opts.services, NAME])
            """The run's key pairs, one per service and the launcher's (:mod:`proto.auth`)."""
            service_bus = BusOptions(stream, "peer", connect=(self.endpoint,),
                                     run_id=self.run_id)
            own_bus = BusOptions(stream, "peer", listen=(self.endpoint,), run_id=self.run_id)
        else:  # one host of several: everything joins the stack's router
            self.endpoint = ", ".join(opts.bus.connect)
            # The source's host starts a run; the others follow whichever run comes.
            self.run_id = opts.bus.run_id or (
                f"run-{uuid.uuid4().hex[:12]}" if "source" in opts.services else "")
            self.keyring = deployment_keys(opts)
            service_bus = own_bus = opts.bus.replace(keys="", trust="", run_id=self.run_id)
        self.fingerprint = self.keyring.fingerprint
        """The fingerprint of the launcher's public key: readers trust the run by it."""
        self.specs = service_specs(opts, service_bus, self.keyring)
        try:
            self.recorder = (RecordWriter(opts.launch.record, self.keys_document())
                             if opts.launch.record else None)
        except OSError as exc:  # a device already full: known before anything starts
            raise preflight.PreflightError(
                f"--record {opts.launch.record}: cannot be written ({exc.strerror})") from None
        self.service = Service(NAME, own_bus, keyring=self.keyring.for_service(NAME))
        self.monitor = StackMonitor(self.service, self.recorder, opts.launch.record_images,
                                    EndOfRun(opts.launch.drain_quiet, opts.launch.drain_max),
                                    expected=list(opts.services))
        quiet = {} if opts.verbose else {ENV_LOG_LEVEL: os.environ.get(ENV_LOG_LEVEL, "WARNING")}
        self.supervisor = Supervisor(self.specs, env=SERVICE_ENV | quiet,
                                     floors=self.monitor.restarting,
                                     insecure=opts.launch.insecure)
        self.exit_codes: dict[str, int | None] = {}
        self.outcome = "stopped"

    def keys_document(self) -> bytes:
        """The run's public keys signed by the launcher (:func:`proto.auth.keys_document`)."""
        return keys_document(self.keyring, self.opts.launch.stream, self.run_id)

    def _answer_keys(self, query: Any) -> None:
        try:
            query.reply(query.key_expr, self.keys_document())
        except Exception as exc:  # a query whose asker is gone: nothing to answer
            log.debug("keys query not answered: %s", exc)

    def __enter__(self) -> Stack:
        try:
            self.service.open()
            self.service.queryable(keys_key(self.opts.launch.stream), self._answer_keys)
            self.monitor.subscribe()
            self.service.ready(f"listening on {self.endpoint}, run {self.run_id}")
            log.info("stack bus at %s (other programs can connect there)", self.endpoint)
            run = self.run_id or "of the source's host"
            print(f"aamtrack run: run {run}, launcher key "
                  f"{self.fingerprint} (readers check the run's messages against it: "
                  f"--trust {self.fingerprint})", file=sys.stderr, flush=True)
            self.supervisor.start()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def wait(self) -> str:
        """Watch the run until it ends; the outcome (see :func:`wait_for_end`).

        A run whose rerun service serves its recording goes on after the end
        of stream until stopped (see :func:`serve_until_stopped`).
        """
        with run_progress(self.opts, self.monitor):
            self.outcome = wait_for_end(self.service, self.supervisor, self.monitor, self.opts)
        rerun = self.opts.services.get("rerun")
        if self.outcome == "done" and getattr(rerun, "serve", None) is not None:
            self.outcome = serve_until_stopped(self.service, self.supervisor, rerun.serve)
        return self.outcome

    def __exit__(self, *exc: object) -> None:
        try:
            self.exit_codes = self.supervisor.stop()
            self.monitor.wait_for_final_statuses([s.name for s in self.specs], FINAL_STATUS_WAIT)
            self.finish_recordings()
        finally:
            self.service.close()
            if self.recorder is not None:
                self.recorder.close()
            if self.opts.bus is None:
                for name in [s.name for s in self.specs]:
                    remove_socket(service_listen(self.endpoint, self.run_id, name))
                remove_socket(self.endpoint)

    def finish_recordings(self) -> None:
        """Give its footer to every part of the ``.rrd`` whose Rerun logger did not close it
        (killed: no last status "stopped", which a logger sends once its file is closed;
        :mod:`services.rerun_logger.files`); each is said in the summary's events."""
        rerun = self.opts.services.get("rerun")
        if getattr(rerun, "rrd", None) is None or "rerun" not in self.exit_codes:
            return
        from services.rerun_logger.files import finish, unfinished_parts

        closed = {k for (name, k), status in self.monitor.incarnations.items()
                  if name == "rerun" and status.state == "stopped"}
        for path in unfinished_parts(rerun.rrd, self.supervisor.restarts("rerun"), closed):
            why = finish(path)
            self.supervisor.events.append(
                f"{path}: its logger did not close it; finished with its footer" if not why else
                f"{path}: its logger did not close it, and its footer could not be written "
                f"({why})")
            log.info("%s", self.supervisor.events[-1])

    def summary(self) -> dict[str, Any]:
        """The run's summary: the monitor's counts, outcome, exit codes and events."""
        insecure = [self.insecure] if self.insecure else []
        return self.monitor.summary(exclude=NAME) | {
            "run_id": self.run_id, "endpoint": self.endpoint, "outcome": self.outcome,
            "exit_codes": self.exit_codes, "events": list(self.supervisor.events),
            "launcher_key": self.fingerprint,
            "insecure": insecure + list(self.supervisor.insecure_notes)}


def prepared(opts: StackOptions) -> StackOptions:
    """Check everything before any process starts, and name the models.

    Raises
    ------
    preflight.PreflightError
    """
    if opts.launch.endpoint:
        preflight.check_endpoint(opts.launch.endpoint, explicit=True)
    # Only the services' own options are checked with it: any endpoint of the right form does.
    bus = BusOptions(opts.launch.stream, "peer", connect=("tcp/127.0.0.1:7447",),
                     run_id="run-check")
    preflight.check_service_args(opts, bus)
    deployment_keys(opts)
    preflight.check_viewer(opts)
    preflight.check_outputs(opts)
    preflight.check_input(opts)
    preflight.check_models(opts)
    opts = preflight.prepare_models(opts)
    # Now that the models are named: the classifier was made for the fits of these.
    preflight.check_classifier(opts.services.get("expression"), opts.services.get("fitter"))
    return opts


def run_stack(opts: StackOptions) -> int:
    """Run the stack as ``opts`` says; the exit code (see the module notes)."""
    try:
        return _run_stack(opts)
    except KeyboardInterrupt:  # before the launcher's own stop handling was in place
        say_unwritten(opts)
        raise


def _run_stack(opts: StackOptions) -> int:
    try:
        opts = prepared(opts)
    except (preflight.PreflightError, OptionError) as exc:
        print(f"aamtrack run: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    try:
        with Stack(opts) as stack:
            stack.wait()
    except (preflight.PreflightError, HandoverError) as exc:
        print(f"aamtrack run: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    summary = stack.summary()
    print(summary_table(summary))
    unsaved = ""
    if opts.launch.summary:
        try:
            Path(opts.launch.summary).write_text(json.dumps(summary, indent=2))
            Path(f"{opts.launch.summary}.trust").write_text(f"{stack.fingerprint}\n")
        except OSError as exc:  # no half-written JSON left behind
            Path(opts.launch.summary).unlink(missing_ok=True)
            unsaved = f"--summary {opts.launch.summary}: cannot be written ({exc.strerror})"
    say_unwritten(opts)
    if stack.outcome == "done" and (problem := output_problem(stack.monitor)):
        stack.outcome = problem  # found as the run ended (the logger's file at its close)
    code = exit_code(stack.outcome, summary)
    if unsaved:
        print(f"aamtrack run: error: {unsaved}", file=sys.stderr)
    return code or (EXIT_FAILED if unsaved else 0)
