#!/usr/bin/env bash
# The main job on a fresh machine: set up, then run the whole tracking stack on
# a video (every service its own process over Zenoh), writing a Rerun recording
# (out/run.rrd, checked by `rerun rrd verify`), every result message (out/run.rec) and a
# summary (out/run_summary.json); then train a model on IMM Frontal and show it.
#
# Options given to this script go to `aamtrack run` (the tests give the small model they
# train: tests/test_first_command.py runs this script as the README says);
# AAMTRACK_OUT names another folder to write to than out/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
DATA=${AAMTRACK_DATA:-../shared/data}
OUT=${AAMTRACK_OUT:-out}
mkdir -p "$OUT"
.venv/bin/aamtrack run --video "$DATA/videos/single_face.mp4" --rrd "$OUT/run.rrd" \
    --record "$OUT/run.rec" --summary "$OUT/run_summary.json" "$@"
.venv/bin/rerun rrd verify "$OUT/run.rrd"
.venv/bin/aamtrack train --data imm_frontal --out "$OUT/imm_frontal.npz"
.venv/bin/aamtrack model modes "$OUT/imm_frontal.npz" --out "$OUT/imm_modes.png"
.venv/bin/aamtrack model reconstruct "$OUT/imm_frontal.npz" "$DATA/imm_frontal/01_02.jpg" \
    "$DATA/imm_frontal/01_02.asf" --out "$OUT/imm_reconstruction.png"
echo "demo: done; view the run with .venv/bin/rerun $OUT/run.rrd"
