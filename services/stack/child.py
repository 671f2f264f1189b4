"""The body of a service process the launcher starts: ``python -m services.stack.child
MODULE NICE KEYFD ARGV...``.

It makes itself non-dumpable before anything else, then asks for its keys over the
inherited socket ``KEYFD`` (``-``: none; :mod:`services.bus.handover`), asks to die with the
launcher, lowers its priority by ``NICE``, imports ``MODULE`` and exits with the code of
``MODULE.main(ARGV)``. A launcher that refuses it its keys (it is traced, or cannot be made
non-dumpable) says why; the process then exits 2 without a word.
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


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
