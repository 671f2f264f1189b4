"""``python -m bench``: list the benchmarks, or run one by name."""

import sys

from bench.tool import main

sys.exit(main(sys.argv[1:]))
