#!/bin/bash
# Issue 17: a held-out set's whole measurement, once, with the shipped attention and network (only measured,
# never tuned on). Perception (calibrate_attention.py palette-evaluate on splits.py's current held-out set)
# and the exposure check (exposure_wide.py on EXPOSURE_SEED_BASE) run side by side, one core each; then
# picking under `cell` (run_heldout.sh), Ours on the default palette on the same 100 picking seeds
# (default100), and picking under `none`. Writes into OUT: palette_evaluate.txt, attention_palettes.json,
# exposure_evaluation.txt, NAME/, default100/, default100.txt, NAME_none/. 40-75 min on 2 cores
# (40 for the fourteenth set in the thirty-second session, 67-75 for the earlier ones).
#
#     scripts/measure_heldout_set.sh OUT NAME PICKING_SEED_BASE EXPOSURE_SEED_BASE
#     scripts/measure_heldout_set.sh runs/s31 heldout14 916900000 917000000   # the fourteenth set
#
# Each set's run (docs/experiments_s*/run_heldout*.sh, from the eleventh) calls this script with its
# arguments; palette-evaluate reads splits.py as it stands, so an earlier set is reproduced at its commit.
set -euo pipefail
usage() { sed -n 2,14p "$0" >&2; exit 2; }
[ $# -eq 4 ] || { echo "measure_heldout_set.sh: expected 4 arguments, got $#" >&2; usage; }
[ -n "$1" ] || { echo "measure_heldout_set.sh: OUT is empty" >&2; usage; }
for number in "$3" "$4"; do
  [[ $number =~ ^[0-9]+$ ]] || { echo "measure_heldout_set.sh: '$number' is not a whole number" >&2; usage; }
done
[[ $2 =~ ^[A-Za-z0-9_.-]+$ ]] || { echo "measure_heldout_set.sh: NAME '$2' is not a plain file name" >&2; usage; }
out=$(realpath -m -- "$1") name=$2 picking=$3 exposure=$4
cd "$(dirname "$0")/.."
set +u
source scripts/env.sh >/dev/null || { echo "measure_heldout_set.sh: scripts/env.sh failed (run make setup)" >&2; exit 1; }
set -u
mkdir -p "$out"
date; git rev-parse HEAD
python scripts/calibrate_attention.py palette-evaluate --json "$out/attention_palettes.json" \
  > "$out/palette_evaluate.txt" 2> "$out/palette_evaluate.err" &
perception=$!
python docs/experiments_s11/exposure_wide.py report --seed-base "$exposure" \
  > "$out/exposure_evaluation.txt" 2> "$out/exposure_evaluation.err"
wait "$perception"
date
RULES=cell scripts/run_heldout.sh "$out/$name" "$picking" 100
date
python -m impurity_learning.eval_cli --methods ours --rules cell --episodes 100 --palette-groups default \
  --seed-base "$picking" --json "$out/default100/results.json" --markdown "$out/default100/results.md" \
  --no-progress --no-resume --jobs 2
python docs/experiments_s16/default100.py extract "$out/$name/results.json" "$out/default100/results.json" \
  "$out/default100_episodes.jsonl"
python docs/experiments_s16/default100.py report "$out/default100_episodes.jsonl" > "$out/default100.txt"
date
RULES=none scripts/run_heldout.sh "$out/${name}_none" "$picking" 100
date
