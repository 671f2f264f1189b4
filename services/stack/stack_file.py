"""The stack file (``deploy/stack.toml``): which services run on which host, with which options.

::

    [bus]
    stream = "cam0"
    router = "tcp/compute.example.lan:7447"   # what every host connects to
    keys = "run.keys"                         # aamtrack keys: on every host, mode 600

    [hosts.compute]
    address = "compute.example.lan"           # where its services listen (peer mode)
    router = true                             # this host runs the router
    services = ["detector", "fitter", "pose", "expression", "ar"]
    # mode = "client"                         # peer by default; client listens on nothing

    [services.fitter]                         # the fitter's options, by name
    warp = "auto"

Each ``[services.NAME]`` table holds the service's options under their field
names (``services/<name>/options.py``), checked like the command line.
``aamtrack run --stack FILE`` runs every service of the file on this machine;
with ``--host NAME`` only that host's, connected to the file's router;
``aamtrack service NAME --stack FILE --host HOST`` runs one.

In ``peer`` mode a host's services listen on its ``address`` (any port) and the router
introduces the peers of every host to each other, which then connect directly: a peer
that listens nowhere is reached by no peer of another host. In ``client`` mode they listen
on nothing and everything goes through the router. ``keys`` (relative to the stack file's
folder) is the deployment's keys file (:mod:`services.bus.trust`): every host needs it.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from proto.zenoh_config import MODES
from services.bus.connection import DEFAULT_STREAM, BusOptions
from services.bus.options import OptionError, Options, options_of_mapping
from services.stack.registry import SERVICES


@dataclass(frozen=True)
class Host:
    """One host of the stack file."""

    name: str
    services: tuple[str, ...]
    mode: str = "peer"
    router: bool = False
    address: str = ""


@dataclass(frozen=True)
class StackFile:
    """A parsed stack file.

    Attributes
    ----------
    stream : str
    router : str
        The endpoint every host connects to (empty: run on one machine only).
    hosts : dict of str to Host
    services : dict of str to Options
        The options of each service named in a ``[services.NAME]`` table or on a host.
    """

    stream: str
    router: str
    hosts: dict[str, Host]
    services: dict[str, Any] = field(default_factory=dict)
    keys: str = ""
    """The keys file, resolved against the stack file's folder (empty: none named)."""

    def host(self, name: str) -> Host:
        if name not in self.hosts:
            raise OptionError(f"--host {name!r}: the stack file has hosts "
                              f"{', '.join(self.hosts) or '(none)'}")
        return self.hosts[name]

    def services_of(self, host: str | None = None) -> dict[str, Any]:
        """The options of the services of ``host`` (all hosts when None), in pipeline order."""
        wanted = (self.host(host).services if host is not None
                  else {s for h in self.hosts.values() for s in h.services})
        return {name: self.services[name] for name in SERVICES if name in wanted}

    def bus(self, host: str) -> BusOptions:
        """The bus options of the services of ``host``: connected to the router, listening
        on the host's address in peer mode, with the keys file."""
        h = self.host(host)
        if not self.router:
            raise OptionError("the stack file's [bus] gives no router for its hosts to join")
        listen = (f"tcp/{h.address or '0.0.0.0'}:0",) if h.mode == "peer" else ()
        return BusOptions(self.stream, h.mode, listen=listen, connect=(self.router,),
                          keys=self.keys)

    def elsewhere(self, host: str) -> dict[str, tuple[str, ...]]:
        """The services of every other host, by host."""
        self.host(host)
        return {name: h.services for name, h in self.hosts.items()
                if name != host and h.services}


def _table(data: dict[str, Any], key: str, where: str) -> dict[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise OptionError(f"{where}: [{key}] must be a table")
    return value


def _host(name: str, data: Any, where: str) -> Host:
    if not isinstance(data, dict):
        raise OptionError(f"{where}: [hosts.{name}] must be a table")
    services = data.get("services", [])
    unknown = [s for s in services if s not in SERVICES]
    if not isinstance(services, list) or unknown:
        raise OptionError(f"{where}: hosts.{name}.services: unknown services {unknown}; "
                          f"services are {', '.join(SERVICES)}")
    mode = data.get("mode", "peer")
    if mode not in MODES:
        raise OptionError(f"{where}: hosts.{name}.mode {mode!r}: choose one of {MODES}")
    return Host(name, tuple(services), mode, bool(data.get("router", False)),
                str(data.get("address", "")))


def read_stack_file(path: str | Path) -> StackFile:
    """Read and check a stack file.

    Raises
    ------
    OptionError
        Naming the file and what is wrong in it.
    """
    where = str(path)
    try:
        data = tomllib.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise OptionError(f"--stack {where}: cannot read it: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise OptionError(f"--stack {where}: not valid TOML: {exc}") from None
    bus = _table(data, "bus", where)
    hosts = {name: _host(name, h, where) for name, h in _table(data, "hosts", where).items()}
    tables = _table(data, "services", where)
    unknown = sorted(set(tables) - set(SERVICES))
    if unknown:
        raise OptionError(f"{where}: [services] names unknown services {unknown}")
    named = set(tables) | {s for h in hosts.values() for s in h.services}
    services: dict[str, Options] = {
        name: options_of_mapping(SERVICES[name].options, tables.get(name, {}),
                                 f"{where} [services.{name}]")
        for name in SERVICES if name in named
    }
    stream = str(bus.get("stream", DEFAULT_STREAM))
    keys = str(bus.get("keys", ""))
    if keys:
        keys = str(Path(path).parent / Path(keys).expanduser())
    return StackFile(stream, str(bus.get("router", "")), hosts, services, keys)
