#!/usr/bin/env bash
# The main job on a fresh machine: set up, then train a model on IMM Frontal and
# show it (summary, mode variation and a reconstruction) under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
DATA=${AAMTRACK_DATA:-../shared/data}
mkdir -p out
.venv/bin/aamtrack train --data imm_frontal --out out/imm_frontal.npz
.venv/bin/aamtrack model modes out/imm_frontal.npz --out out/imm_modes.png
.venv/bin/aamtrack model reconstruct out/imm_frontal.npz "$DATA/imm_frontal/01_02.jpg" \
    "$DATA/imm_frontal/01_02.asf" --out out/imm_reconstruction.png
