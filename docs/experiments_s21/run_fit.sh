#!/usr/bin/env bash
# Twenty-first session (docs/experiments.md): the refit with the orientation-matched features on unclipped
# cells, and the data its shipping criterion reads, in order. From the repository root after
# `source scripts/env.sh`; writes runs/s21/. Each step's output is its own log there.
set -euo pipefail
mkdir -p runs/s21
lv=docs/experiments_s17/loop_views.py
ca=scripts/calibrate_attention.py
[ -f runs/s21/views_inv.npz ] || python $lv collect invisible 160 runs/s21/views_inv.npz
[ -f runs/s21/views_chal.npz ] || python $lv collect challenging 80 runs/s21/views_chal.npz --start 200
[ -f runs/s21/views_rand.npz ] || python $lv collect random 80 runs/s21/views_rand.npz --start 400
views=(runs/s21/views_inv.npz runs/s21/views_chal.npz runs/s21/views_rand.npz)
python $lv subset even runs/s21/views_even.npz "${views[@]}"
python $lv subset odd runs/s21/views_odd.npz "${views[@]}"
# the model the criterion judges (renders and caches the first views the others reuse)
python $ca verifier-fit --own-layouts --loop-views "${views[@]}" --threshold-on first-views \
    --model-json runs/s21/verifier_oriented.json > runs/s21/fit_oriented.txt 2>&1
# the last look's threshold, chosen with a model not fitted on the views it is chosen on
python $ca verifier-fit --own-layouts --loop-views runs/s21/views_even.npz --threshold-on first-views \
    --model-json runs/s21/verifier_even.json > runs/s21/fit_even.txt 2>&1 &
python docs/experiments_s11/exposure_wide.py collect --seed-base 51000 --count-scale 2 \
    > runs/s21/exposure_collect.txt 2>&1
wait
python docs/experiments_s21/last_look.py runs/s21/verifier_even.json runs/s21/views_odd.npz \
    > runs/s21/last_look.txt 2>&1
t=$(sed -n 's/^chosen t = //p' runs/s21/last_look.txt)
python docs/experiments_s11/exposure_wide.py report --seed-base 51000 --count-scale 2 \
    --model runs/s21/verifier_oriented.json --last-look "${t:-0.35}" > runs/s21/exposure51000.txt 2>&1
python docs/experiments_s11/exposure_wide.py report --seed-base 51000 --count-scale 2 \
    > runs/s21/exposure51000_shipped.txt 2>&1
echo "run_fit: done"
