#!/usr/bin/env bash
# Thirtieth session (docs/experiments.md, thirtieth section; criterion written there before this ran): the stall
# look of the twenty-seventh session (push_out.py --stall K T: on the K-th OCCLUDED_REGION view in a row the view
# is attended again with verifier_threshold T and the known product, and the count starts over) at a lower
# threshold, 0.25 instead of 0.52, against the shipped cell. Tuning palettes (the named ones and random-700 ...
# 799), fresh tuning seeds registered in splits.TUNING_SEED_BLOCKS: challenging 9 500-9 699, invisible 9 700-9 899
# (--start 200), random 9 900-9 999 (--start 400); the same seeds in both arms. Both arms record the nearest
# target's pose at each grasp (--grasp-geometry: reads only, the episodes are unchanged), a diagnosis of failed
# grasps beside the test. Usage, from the repository root after `source scripts/env.sh`:
#     docs/experiments_s30/run_stall25.sh shipped|stall      (one arm per core; about 50 min side by side)
set -euo pipefail
arm=$1
out=runs/s30/stall25_$arm
mkdir -p "$out"
extra=()
case "$arm" in
    shipped) ;;
    stall) extra=(--stall 5 0.25) ;;
    *) echo "usage: $0 shipped|stall" >&2; exit 2 ;;
esac
common=(--seed-base 9500 --random-from 700 --random-palettes 100 --jobs 1 --grasp-geometry)
python docs/experiments_s14/push_out.py run challenging 200 "$out/challenging.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run invisible 200 "$out/invisible.jsonl" --start 200 "${common[@]}" \
    "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 400 "${common[@]}" "${extra[@]}"
