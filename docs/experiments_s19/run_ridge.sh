#!/usr/bin/env bash
# Nineteenth session (docs/experiments.md): the candidate rule grasp_along_ridge (push_out.py --with) against the
# shipped cell preset on tuning palettes random-700 ... 799, the same seeds 14000-14299. Usage, from the
# repository root after `source scripts/env.sh`:  docs/experiments_s19/run_ridge.sh shipped|ridge   (one arm per core)
set -euo pipefail
arm=$1
out=runs/s19/ridge_$arm
mkdir -p "$out"
extra=()
if [ "$arm" = ridge ]; then
    extra=(--with grasp_along_ridge)
fi
common=(--seed-base 14000 --random-from 700 --random-only --random-palettes 100 --jobs 1)
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run challenging 100 "$out/challenging.jsonl" --start 100 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run invisible 100 "$out/invisible.jsonl" --start 200 "${common[@]}" "${extra[@]}"
