#!/usr/bin/env bash
# Twenty-first session (docs/experiments.md): the shipped verifier against the refit whose orientation-matched
# features read unclipped cells only (runs/s21/verifier_oriented.json, written by the verifier-fit command in
# experiments.md) on tuning palettes neither was fitted on (random-900 ... 999) and fresh tuning seeds
# 18000-18299: invisible k < 100, challenging 100-199, random 200-299. Usage, from the repository root after
# `source scripts/env.sh`:
#   [JOBS=2] docs/experiments_s21/run_oriented.sh shipped|oriented      (one arm per core unless JOBS)
set -euo pipefail
arm=$1
out=runs/s21/picking_$arm
mkdir -p "$out"
extra=()
if [ "$arm" = oriented ]; then  # the refit with its own last look (runs/s21/last_look.txt, run_fit.sh)
    extra=(--verifier runs/s21/verifier_oriented.json --last-look "$(sed -n 's/^chosen t = //p' runs/s21/last_look.txt)")
fi
common=(--seed-base 18000 --random-from 900 --random-only --random-palettes 100 --jobs "${JOBS:-1}")
python docs/experiments_s14/push_out.py run invisible 100 "$out/invisible.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run challenging 100 "$out/challenging.jsonl" --start 100 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 200 "${common[@]}" "${extra[@]}"
