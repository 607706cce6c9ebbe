#!/usr/bin/env bash
# Nineteenth session (docs/experiments.md): the candidate rule grasp_along_ridge (push_out.py --with) against the
# shipped cell preset, one episode per seed, the same seeds in both arms. Usage, from the repository root after
# `source scripts/env.sh` (one arm per core):
#   docs/experiments_s19/run_ridge.sh shipped|ridge      # first test: random-700 ... 799, seeds 14000-14299
#   docs/experiments_s19/run_ridge.sh shipped|ridge 2    # the revision's test: random-600 ... 699, seeds 15000-15299
#   docs/experiments_s19/run_ridge.sh shipped|ridge 3    # the second revision's: random-500 ... 599, seeds 16000-16299
set -euo pipefail
arm=$1
if [ "${2:-1}" = 2 ]; then
    out=runs/s19/ridge2_$arm seed_base=15000 random_from=600
elif [ "${2:-1}" = 3 ]; then
    out=runs/s19/ridge3_$arm seed_base=16000 random_from=500
else
    out=runs/s19/ridge_$arm seed_base=14000 random_from=700
fi
mkdir -p "$out"
extra=()
if [ "$arm" = ridge ]; then
    extra=(--with grasp_along_ridge)
fi
common=(--seed-base "$seed_base" --random-from "$random_from" --random-only --random-palettes 100 --jobs 1)
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run challenging 100 "$out/challenging.jsonl" --start 100 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run invisible 100 "$out/invisible.jsonl" --start 200 "${common[@]}" "${extra[@]}"
