"""``python -m services`` runs the ``aamtrack`` command."""

import contextlib
import ctypes
import sys

# Before any other import: a launcher's keys are made later in this process (see
# services.cli._first_of_all).
with contextlib.suppress(OSError, AttributeError):
    ctypes.CDLL(None).prctl(4, 0, 0, 0, 0)  # PR_SET_DUMPABLE 0

try:
    from services.cli import main

    code = main()
except KeyboardInterrupt:  # Ctrl-C before the command's own handling is in place
    print("aamtrack: interrupted", file=sys.stderr)
    code = 130
sys.exit(code)
