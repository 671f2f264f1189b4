#!/usr/bin/env bash
# The test command: set up on a fresh machine, lint, then run the whole suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
export AAMTRACK_CACHE=${AAMTRACK_CACHE:-$HOME/.cache/aamtrack}
.venv/bin/ruff check .
.venv/bin/python -m pytest "$@"
