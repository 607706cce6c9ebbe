#!/usr/bin/env bash
# Twenty-seventh session (docs/experiments.md): a last look after five heap pushes in a row (push_out.py
# --stall 5 0.52, 0.52 being AttentionParams.verifier_last_look), with the known product, against the shipped
# loop; tuning palettes (the named ones and random-600 ... 699), fresh tuning seeds 8 300-8 699: challenging
# 8 300-8 499, invisible 8 500-8 599 (--start 200), random 8 600-8 699 (--start 300). Usage, from the
# repository root after `source scripts/env.sh`:
#     docs/experiments_s27/run_stall.sh shipped|stall      (one arm per core; about 45 min side by side)
set -euo pipefail
arm=$1
out=runs/s27/stall_$arm
mkdir -p "$out"
extra=()
if [ "$arm" = stall ]; then
    extra=(--stall 5 0.52)
fi
common=(--seed-base 8300 --random-from 600 --random-palettes 100 --jobs 1)
python docs/experiments_s14/push_out.py run challenging 200 "$out/challenging.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run invisible 100 "$out/invisible.jsonl" --start 200 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 300 "${common[@]}" "${extra[@]}"
