#!/usr/bin/env bash
# Twenty-ninth session (docs/experiments.md): the candidate pose rule grasp_square_to_faces (push_out.py --with)
# against the shipped cell; tuning palettes (the named ones and random-500 ... 599), fresh tuning seeds:
# invisible 9 100-9 299 (grasp geometry recorded), random 9 300-9 399 (--start 200), challenging 9 400-9 499
# (--start 300). Usage, from the repository root after `source scripts/env.sh`:
#     docs/experiments_s29/run_square.sh shipped|square      (one arm per core; about 40 min side by side)
set -euo pipefail
arm=$1
out=runs/s29/square_$arm
mkdir -p "$out"
extra=()
if [ "$arm" = square ]; then
    extra=(--with grasp_square_to_faces)
fi
common=(--seed-base 9100 --random-from 500 --random-palettes 100 --jobs 1)
python docs/experiments_s14/push_out.py run invisible 200 "$out/invisible.jsonl" --grasp-geometry "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 200 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run challenging 100 "$out/challenging.jsonl" --start 300 "${common[@]}" "${extra[@]}"
