"""``python -m services`` runs the ``aamtrack`` command."""

import sys

try:
    from services.cli import main

    code = main()
except KeyboardInterrupt:  # Ctrl-C before the command's own handling is in place
    print("aamtrack: interrupted", file=sys.stderr)
    code = 130
sys.exit(code)
