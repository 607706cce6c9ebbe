#!/usr/bin/env bash
# Eighteenth session (docs/experiments.md): the stall-breaker (push_out.py --stall 5 0.5) against the shipped
# loop on fresh tuning palettes random-900 ... 999, the same seeds 13000-13299. Usage, from the repository root
# after `source scripts/env.sh`:  docs/experiments_s18/run_stall.sh shipped|stall   (one arm per core)
set -euo pipefail
arm=$1
out=runs/s18/stall_$arm
mkdir -p "$out"
extra=()
if [ "$arm" = stall ]; then
    extra=(--stall 5 0.5)
fi
common=(--seed-base 13000 --random-from 900 --random-only --random-palettes 100 --jobs 1)
python docs/experiments_s14/push_out.py run challenging 100 "$out/challenging.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run invisible 100 "$out/invisible.jsonl" --start 100 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 200 "${common[@]}" "${extra[@]}"
