#!/usr/bin/env bash
# Thirtieth session (docs/experiments.md, thirtieth section; criterion written there before this ran): the
# candidate pose rule grasp_turned_along_ridge (push_out.py --with) against the shipped cell. Tuning palettes
# (the named ones and random-800 ... 899), fresh tuning seeds registered in splits.TUNING_SEED_BLOCKS:
# challenging 10 480-10 679, random 10 680-10 779 (--start 200), invisible 10 780-10 879 (--start 300); the same
# seeds in both arms, grasp geometry recorded (reads only). Usage, from the repository root after
# `source scripts/env.sh`:
#     docs/experiments_s30/run_ridge_pose.sh shipped|ridge      (one arm per core; about an hour side by side)
set -euo pipefail
arm=$1
out=runs/s30/ridge_$arm
mkdir -p "$out"
extra=()
case "$arm" in
    shipped) ;;
    ridge) extra=(--with grasp_turned_along_ridge) ;;
    *) echo "usage: $0 shipped|ridge" >&2; exit 2 ;;
esac
common=(--seed-base 10480 --random-from 800 --random-palettes 100 --jobs 1 --grasp-geometry)
python docs/experiments_s14/push_out.py run challenging 200 "$out/challenging.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 200 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run invisible 100 "$out/invisible.jsonl" --start 300 "${common[@]}" \
    "${extra[@]}"
