#!/bin/bash
# Twenty-second session: the tenth held-out set (splits.py, fixed in a3d09ac before any of it was rendered),
# measured once with the shipped attention and network. Perception (palette-evaluate) and the exposure check
# run side by side (one core each), then picking under `cell` and under `none`. Writes into runs/s22/.
#
#     docs/experiments_s22/run_heldout10.sh          # about 75 min on 2 cores
set -euo pipefail
cd "$(dirname "$0")/../.."
set +u
source scripts/env.sh >/dev/null || { echo "run_heldout10.sh: scripts/env.sh failed (run make setup)" >&2; exit 1; }
set -u
out=runs/s22
mkdir -p "$out"
date; git rev-parse HEAD
python scripts/calibrate_attention.py palette-evaluate --json "$out/attention_palettes.json" \
  > "$out/palette_evaluate.txt" 2> "$out/palette_evaluate.err" &
perception=$!
python docs/experiments_s11/exposure_wide.py report --seed-base 909000000 \
  > "$out/exposure_evaluation.txt" 2> "$out/exposure_evaluation.err"
wait "$perception"
date
RULES=cell scripts/run_heldout.sh "$out/heldout10" 908900000 100
RULES=none scripts/run_heldout.sh "$out/heldout10_none" 908900000 100
date
