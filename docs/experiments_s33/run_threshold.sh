#!/usr/bin/env bash
# Thirty-third session (docs/experiments.md): the verifier's threshold at a 2 % false-TARGET cap against the
# shipped one, every check of the criterion written there, in order. From the repository root after
# `source scripts/env.sh`; writes runs/s33/. Usage: docs/experiments_s33/run_threshold.sh [step ...]
# (steps: threshold check exposure picking; default all).
set -euo pipefail
mkdir -p runs/s33
steps=("${@:-threshold check exposure picking}")
steps=(${steps[*]})
model=runs/s33/verifier_cap2.json
for step in "${steps[@]}"; do
    case $step in
    threshold)
        python docs/experiments_s33/cap_threshold.py 0.02 --model-json $model > runs/s33/cap_threshold.txt 2>&1 ;;
    check)
        python docs/experiments_s33/check_palettes.py $model > runs/s33/check_palettes.txt 2>runs/s33/check.err ;;
    exposure)
        python docs/experiments_s11/exposure_wide.py collect --seed-base 72100 --count-scale 2 \
            > runs/s33/exposure_collect.txt 2>&1
        python docs/experiments_s11/exposure_wide.py report --seed-base 72100 --count-scale 2 \
            > runs/s33/exposure72100_shipped.txt 2>&1
        python docs/experiments_s11/exposure_wide.py report --seed-base 72100 --count-scale 2 --model $model \
            > runs/s33/exposure72100_cap2.txt 2>&1 ;;
    picking)
        # docs/experiments_s14/paired_picking.sh since the thirty-sixth session (the same runs; it adds the
        # pooled comparison at the top of runs/s33/picking_paired.txt)
        bash docs/experiments_s14/paired_picking.sh runs/s33 picking cap2 --verifier $model -- \
            --seed-base 13300 --random-from 600 --random-only --random-palettes 100 ;;
    *) echo "unknown step $step" >&2; exit 2 ;;
    esac
done
echo "run_threshold: ${steps[*]} done"
