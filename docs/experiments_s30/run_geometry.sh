#!/usr/bin/env bash
# Thirtieth session (docs/experiments.md), a diagnosis on tuning data only: where the shipped cell's grasps fail
# in random and challenging scenes, with the nearest target's pose and contacts recorded at each grasp
# (push_out.py --grasp-geometry). Tuning palettes (the named ones and random-700 ... 799), fresh tuning seeds
# registered in splits.TUNING_SEED_BLOCKS: random 9 500-9 699, challenging 9 700-9 899 (--start 200).
# Nothing shipped is chosen on these runs without a test of its own on other seeds. Usage, from the repository
# root after `source scripts/env.sh`:
#     docs/experiments_s30/run_geometry.sh random|challenging      (one per core; about 20 min side by side)
set -euo pipefail
scenario=$1
out=runs/s30/geometry
mkdir -p "$out"
common=(--seed-base 9500 --random-from 700 --random-palettes 100 --jobs 1 --grasp-geometry)
case "$scenario" in
    random) python docs/experiments_s14/push_out.py run random 200 "$out/random.jsonl" "${common[@]}" ;;
    challenging) python docs/experiments_s14/push_out.py run challenging 200 "$out/challenging.jsonl" --start 200 \
        "${common[@]}" ;;
    *) echo "usage: $0 random|challenging" >&2; exit 2 ;;
esac
