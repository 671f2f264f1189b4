"""The run's keys (made by the launcher, or a deployment's keys file for one host of a
stack spread over several), and the other hosts a host waits for."""

from __future__ import annotations

from proto.auth import LAUNCHER, Keyring
from services.bus.trust import harden, insecurity, read_keys_file
from services.stack import preflight
from services.stack.options import StackOptions


def secure_launcher(insecure: bool) -> str:
    """Make this process non-dumpable before any key exists; why it cannot keep keys from
    other processes of its user ("" when it can).

    Raises
    ------
    preflight.PreflightError
        When it cannot, unless ``insecure``.
    """
    harden()
    problem = insecurity()
    if problem and not insecure:
        raise preflight.PreflightError(f"the launcher cannot keep the run's keys: {problem} "
                                       "(--insecure runs anyway, and says so)")
    return f"launcher: {problem}" if problem else ""


def deployment_keys(opts: StackOptions) -> Keyring:
    """The keys of a stack spread over several hosts: the keys file its stack file names
    (empty on one host, where the launcher makes the run's).

    Raises
    ------
    preflight.PreflightError
        When there is none, or it cannot be used.
    """
    if opts.bus is None:
        return Keyring()
    if not opts.bus.keys:
        raise preflight.PreflightError(
            "the stack file names no keys file ([bus] keys = FILE): make one with `aamtrack "
            "keys FILE` and copy it to every host (mode 600), as its certificates")
    try:
        keyring = read_keys_file(opts.bus.keys)
    except ValueError as exc:
        raise preflight.PreflightError(str(exc)) from None
    missing = [n for n in (*opts.services, LAUNCHER) if n not in keyring.secrets]
    if missing:
        raise preflight.PreflightError(f"keys file {opts.bus.keys}: no private key of "
                                       f"{', '.join(missing)} (make one with aamtrack keys)")
    trust = opts.launch.trust.lower()
    if trust and not keyring.fingerprint.startswith(trust):
        raise preflight.PreflightError(
            f"keys file {opts.bus.keys}: its launcher key {keyring.fingerprint} is not the "
            f"trusted {trust}")
    return keyring


def not_joined(heard: set[str], opts: StackOptions) -> dict[str, list[str]]:
    """The other hosts of a stack file some of whose services were never ``heard`` from (a
    signed status), with those services."""
    missing = {host: [s for s in names if s not in heard]
               for host, names in opts.elsewhere.items()}
    return {host: names for host, names in missing.items() if names}


def never_joined(missing: dict[str, list[str]], opts: StackOptions) -> str:
    """The run's outcome when hosts never joined: which, and where they should be."""
    hosts = "; ".join(f"host {h} ({', '.join(n)})" for h, n in missing.items())
    router = ", ".join(opts.bus.connect) if opts.bus else "the router"
    return (f"{hosts} of the stack file never joined: not heard from within "
            f"{opts.launch.start_timeout:g} s (is it running, and can it reach {router}?)")
