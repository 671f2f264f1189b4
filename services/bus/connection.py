"""Where a service connects: the stream, the run, and the Zenoh session settings."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from proto import ProtoError
from proto.keys import check_name
from proto.zenoh_config import MODES, config_from_file, zenoh_config
from services.bus.options import OptionError, Options, option

DEFAULT_STREAM = "cam0"


def _problem_of(check: Callable[[str], str]) -> Callable[[str], str]:
    """An option check from a contract check that raises ``ProtoError``."""

    def problem(value: str) -> str:
        try:
            check(value)
        except ProtoError as exc:
            return exc.reason
        return ""

    return problem


def _check_run_id(value: str) -> None:
    from proto.header import check_run_id  # the header's module imports numpy: not for help

    check_run_id(value)


FINGERPRINT_MIN_HEX = 16
"""The shortest prefix of a launcher key's fingerprint ``--trust`` takes."""


def check_fingerprint(value: str) -> str:
    """A ``--trust`` value: empty, or 16 to 32 hex digits of a launcher key's fingerprint."""
    if value and not (FINGERPRINT_MIN_HEX <= len(value) <= 32
                      and all(c in "0123456789abcdefABCDEF" for c in value)):
        return (f"expected {FINGERPRINT_MIN_HEX} to 32 hex digits of the launcher key's "
                "fingerprint (aamtrack run prints it)")
    return ""


@dataclass(frozen=True)
class BusOptions(Options):
    """The bus options every service and bus tool takes.

    Attributes
    ----------
    stream : str
        Stream id, a key chunk.
    mode : {"peer", "client", "router"}
    listen, connect : tuple of str
        Zenoh endpoints such as ``"tcp/127.0.0.1:7447"``.
    zenoh_config : str
        A Zenoh JSON5 configuration (e.g. ``deploy/zenoh/client-tls.json5``
        for TLS); ``mode`` and any endpoints given here override its own.
    run_id : str
        The run this service belongs to: messages of other runs are ignored
        (and counted). Empty: follow whatever run the stream carries.
    keys : str
        A keys file (:func:`services.bus.trust.read_keys_file`) for a service started on
        its own; a launcher hands its services their keys instead
        (:mod:`services.bus.handover`).
    trust : str
        The fingerprint of a launcher's key (:func:`proto.auth.fingerprint`): a process
        without keys checks what it receives against the public keys that launcher
        publishes (:mod:`services.bus.run_keys`).
    """

    stream: str = option(DEFAULT_STREAM, "stream id", env="AAMTRACK_STREAM",
                         check=_problem_of(check_name))
    mode: str = option("peer", "zenoh mode", choices=MODES, env="AAMTRACK_ZENOH_MODE")
    listen: tuple[str, ...] = option((), "zenoh listen endpoint, repeatable",
                                     metavar="ENDPOINT", env="AAMTRACK_ZENOH_LISTEN")
    connect: tuple[str, ...] = option((), "zenoh endpoint to connect to, repeatable",
                                      metavar="ENDPOINT", env="AAMTRACK_ZENOH_CONNECT")
    zenoh_config: str = option("", "zenoh JSON5 configuration, e.g. TLS; --mode and "
                               "endpoints given override it", metavar="FILE",
                               env="AAMTRACK_ZENOH_CONFIG")
    run_id: str = option("", "accept only messages of this run (set by the launcher)",
                         metavar="RUN", env="AAMTRACK_RUN_ID", check=_problem_of(_check_run_id))
    keys: str = option("", "keys file of a deployment (aamtrack keys): sign what this "
                       "service publishes, check what it receives", metavar="FILE",
                       env="AAMTRACK_KEYS")
    trust: str = option("", "check every message against the run's public keys, as the "
                        "launcher whose key has this fingerprint vouches for them (aamtrack "
                        "run prints it)", metavar="FP", env="AAMTRACK_TRUST",
                        check=check_fingerprint)

    def config(self) -> Any:
        """The ``zenoh.Config``: from ``zenoh_config`` when given, else multicast
        scouting off and the explicit endpoints.

        Raises
        ------
        OptionError
            When the configuration file cannot be read.
        """
        if self.zenoh_config:
            try:
                return config_from_file(self.zenoh_config, self.mode, self.listen, self.connect)
            except (OSError, ValueError) as exc:
                raise OptionError(f"--zenoh-config {self.zenoh_config}: {exc}") from None
        return zenoh_config(self.mode, self.listen, self.connect)
