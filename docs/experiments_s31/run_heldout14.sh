#!/bin/bash
# Thirty-first session: the fourteenth held-out set (splits.py, fixed before any of it was rendered),
# measured once with the shipped attention and network, the picking loop's known product (its near miss left
# out), the cell preset with grasp_square_to_faces and the picking loop's stall look. Perception (palette-evaluate) and the exposure check run side by side (one core each), then picking under `cell`,
# the default palette on the set's 100 picking seeds, and picking under `none`. Writes into runs/s31/.
#
#     docs/experiments_s31/run_heldout14.sh          # about 75 min on 2 cores
set -euo pipefail
cd "$(dirname "$0")/../.."
set +u
source scripts/env.sh >/dev/null || { echo "run_heldout14.sh: scripts/env.sh failed (run make setup)" >&2; exit 1; }
set -u
out=runs/s31
mkdir -p "$out"
date; git rev-parse HEAD
python scripts/calibrate_attention.py palette-evaluate --json "$out/attention_palettes.json" \
  > "$out/palette_evaluate.txt" 2> "$out/palette_evaluate.err" &
perception=$!
python docs/experiments_s11/exposure_wide.py report --seed-base 917000000 \
  > "$out/exposure_evaluation.txt" 2> "$out/exposure_evaluation.err"
wait "$perception"
date
RULES=cell scripts/run_heldout.sh "$out/heldout14" 916900000 100
date
python -m impurity_learning.eval_cli --methods ours --rules cell --episodes 100 --palette-groups default \
  --seed-base 916900000 --json "$out/default100/results.json" --markdown "$out/default100/results.md" \
  --no-progress --no-resume --jobs 2
python docs/experiments_s16/default100.py extract "$out/heldout14/results.json" "$out/default100/results.json" \
  "$out/default100_episodes.jsonl"
python docs/experiments_s16/default100.py report "$out/default100_episodes.jsonl" > "$out/default100.txt"
date
RULES=none scripts/run_heldout.sh "$out/heldout14_none" 916900000 100
date
