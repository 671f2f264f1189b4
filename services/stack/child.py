"""The body of a service process the launcher starts: ``python -m services.stack.child
MODULE NICE KEYFD ARGV...``.

It makes itself non-dumpable before anything else, then asks for its keys over the
inherited socket ``KEYFD`` (``-``: none; :mod:`services.bus.handover`), asks to die with the
launcher, lowers its priority by ``NICE``, imports ``MODULE`` and exits at once with the code
of ``MODULE.main(ARGV)`` (:func:`exit_now`). A launcher that refuses it its keys (it is
traced, or cannot be made non-dumpable) says why; the process then exits 2 without a word.
"""

import contextlib
import ctypes

# First of all, before any other import: nobody of this user may read or trace it now.
with contextlib.suppress(OSError, AttributeError):
    ctypes.CDLL(None).prctl(4, 0, 0, 0, 0)  # PR_SET_DUMPABLE 0

import importlib  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402

from services.bus import trust  # noqa: E402
from services.bus.handover import receive_keys  # noqa: E402
from services.bus.process import die_with_parent  # noqa: E402

EXIT_REFUSED = 2


def main(args: list[str]) -> int:
    module, nice, key_fd, *argv = args
    trust.harden()
    if key_fd != "-":
        handed = receive_keys(int(key_fd))
        if handed is None:
            return EXIT_REFUSED
        trust.keep(*handed)
    die_with_parent()
    if int(nice):
        os.nice(int(nice))
    return int(importlib.import_module(module).main(argv) or 0)


def exit_now(code: int) -> None:
    """End the process with ``code`` at once, once what it printed and logged is out.

    By the time its ``main`` returns, a service has sent its last status and closed its
    outputs (its session, its ``.rrd`` file, its GL worker). The interpreter's teardown
    after that does nothing anyone waits for, yet at nice 5 on a loaded machine it took
    seconds (the Rerun logger's 3.7 s at load 7), which the launcher's stop timeout counts
    before it kills the process. C's ``exit`` skips that teardown but still runs the native
    libraries' exit handlers as a normal exit does (Zenoh's shared-memory clean-up among
    them), which ``os._exit`` would skip; called with the GIL held, so that no other Python
    thread runs meanwhile.
    """
    import logging

    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    try:
        ctypes.PyDLL(None).exit(code)
    except (OSError, AttributeError):  # no C library to ask
        os._exit(code)


if __name__ == "__main__":
    exit_now(main(sys.argv[1:]))  # an exception still takes the interpreter's own way out
