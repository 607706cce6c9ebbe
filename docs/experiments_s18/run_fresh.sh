#!/usr/bin/env bash
# Eighteenth session (docs/experiments.md): the shipped verifier and the sixteenth session's on tuning palettes
# neither saw (random-800 ... 899), the same seeds 12000-12299. Usage, from the repository root after
# `source scripts/env.sh`:  docs/experiments_s18/run_fresh.sh shipped|s16   (one arm per core)
set -euo pipefail
arm=$1
out=runs/s18/fresh_$arm
mkdir -p "$out"
extra=()
if [ "$arm" = s16 ]; then
    git show b53bff8:src/impurity_attention/impurity_attention/core/verifier_model.py > runs/s18/verifier_model_s16.py
    python docs/experiments_s18/model_json.py runs/s18/verifier_model_s16.py runs/s18/verifier_s16.json
    extra=(--verifier runs/s18/verifier_s16.json)
fi
common=(--seed-base 12000 --random-from 800 --random-only --random-palettes 100 --jobs 1)
python docs/experiments_s14/push_out.py run invisible 100 "$out/invisible.jsonl" "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run challenging 100 "$out/challenging.jsonl" --start 100 "${common[@]}" "${extra[@]}"
python docs/experiments_s14/push_out.py run random 100 "$out/random.jsonl" --start 200 "${common[@]}" "${extra[@]}"
