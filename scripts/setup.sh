#!/usr/bin/env bash
# Create .venv and install aamtrack with its test extras. Idempotent: a .venv installed
# from this very pyproject.toml and script is left as it is (its stamp says so; delete
# .venv to install afresh). pip is asked for errors only (-qq): its warnings here are
# about the machine's own pip configuration (an index folder that is absent), not about
# this project.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
STAMP=.venv/.aamtrack-setup
wanted=$(cat pyproject.toml scripts/setup.sh | "$PYTHON" -c \
    "import hashlib, sys; print(hashlib.sha256(sys.stdin.buffer.read()).hexdigest())")
if [ -x .venv/bin/python ] && [ "$(cat "$STAMP" 2>/dev/null)" = "$wanted" ]; then
    exit 0
fi
if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install -qq --upgrade pip
.venv/bin/python -m pip install -qq -e ".[test]"
echo "$wanted" > "$STAMP"
