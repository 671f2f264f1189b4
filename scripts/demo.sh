#!/usr/bin/env bash
# The main job on a fresh machine: set up, then run the whole tracking stack on
# a video (every service its own process over Zenoh), writing a Rerun recording
# (out/run.rrd), every result message (out/run.rec) and a summary
# (out/run_summary.json); then train a model on IMM Frontal and show it.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
DATA=${AAMTRACK_DATA:-../shared/data}
mkdir -p out
.venv/bin/aamtrack run --video "$DATA/videos/single_face.mp4" --rrd out/run.rrd \
    --record out/run.rec --summary out/run_summary.json
.venv/bin/rerun rrd verify out/run.rrd
.venv/bin/aamtrack train --data imm_frontal --out out/imm_frontal.npz
.venv/bin/aamtrack model modes out/imm_frontal.npz --out out/imm_modes.png
.venv/bin/aamtrack model reconstruct out/imm_frontal.npz "$DATA/imm_frontal/01_02.jpg" \
    "$DATA/imm_frontal/01_02.asf" --out out/imm_reconstruction.png
