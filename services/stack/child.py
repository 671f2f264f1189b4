"""The body of a service process the launcher starts: ``python -m services.stack.child
MODULE NICE KEYFD ARGV...``.

It makes itself non-dumpable and reads its keys from the inherited pipe ``KEYFD`` (``-``:
none) before anything else (:mod:`services.bus.trust`), asks to die with the launcher,
lowers its priority by ``NICE``, imports ``MODULE`` and exits with the code of
``MODULE.main(ARGV)``.
"""

from __future__ import annotations

import importlib
import os
import sys

from services.bus.process import die_with_parent
from services.bus.trust import harden, read_key_pipe


def main(args: list[str]) -> int:
    module, nice, key_fd, *argv = args
    harden()
    if key_fd != "-":
        read_key_pipe(int(key_fd))
    die_with_parent()
    if int(nice):
        os.nice(int(nice))
    return int(importlib.import_module(module).main(argv) or 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
