#!/usr/bin/env bash
# Twenty-seventh session (docs/experiments.md): the known product without its near miss (push_out.py
# --near-miss: AttentionParams.known_product_near_miss) against the shipped known product; tuning palettes (the
# named ones and random-600 ... 699), fresh tuning seeds: invisible 8 700-8 899 (--start 400), random
# 8 900-8 999 (--start 600), challenging 9 000-9 099 (--start 700). Usage, from the repository root after
# `source scripts/env.sh`:
#     docs/experiments_s27/run_near_miss.sh shipped|near_miss      (one arm per core; about 40 min side by side)
set -euo pipefail
arm=$1
out=runs/s27/near_miss_$arm
mkdir -p "$out"
extra=()
if [ "$arm" = near_miss ]; then
    extra=(--near-miss)
fi
common=(--seed-base 8300 --random-from 600 --random-palettes 100 --jobs 1)
python docs/experiments_s14/push_out.py run invisible 200 "$out/invisible.jsonl" --start 400 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 600 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run challenging 100 "$out/challenging.jsonl" --start 700 "${common[@]}" "${extra[@]}"
