"""``python -m services`` runs the ``aamtrack`` command."""

import sys

from services.cli import main

sys.exit(main())
