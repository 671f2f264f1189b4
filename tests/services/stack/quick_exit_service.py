"""A stand-in service for tests/services/stack/test_child.py.

``main([MARKS])`` prints a line, logs a line, asks the interpreter to write ``teardown`` to
the file ``MARKS`` at exit (as a library's clean-up at exit would run) and returns 3;
``main([MARKS, "raise"])`` raises instead of returning.
"""

from __future__ import annotations

import atexit
import logging
from pathlib import Path


def main(argv: list[str]) -> int:
    marks = Path(argv[0])
    atexit.register(lambda: marks.write_text("teardown\n"))
    logging.basicConfig(format="%(message)s")
    print("printed", flush=False)
    logging.getLogger("quick").warning("logged")
    if argv[1:] == ["raise"]:
        raise RuntimeError("main failed")
    return 3
