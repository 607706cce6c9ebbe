#!/usr/bin/env bash
# Thirty-sixth session, a screen after the reading (docs/experiments.md, thirty-sixth section; decides nothing):
# the impurity network trained as H4 but with an impurity cell weighing 2 instead of 5 in the loss, the verifier
# refitted with it as the thirty-fifth's C was, and the default palette's exposure set read with it. From the
# repository root after `source scripts/env.sh`; writes runs/s36/. The exposure step passes the network
# (--network; the run itself, at a589447, copied it where attention reads the shipped one and removed it
# after, which would now delete the shipped network).
# Usage: docs/experiments_s36/run_weight.sh [step ...] (steps: network fit exposure; default all).
set -euo pipefail
out=runs/s36
mkdir -p $out
steps=("${@:-network fit exposure}")
steps=(${steps[*]})
net=$out/impurity_net_w2.pt
model=$out/verifier_w2.json
views=(runs/s34/views_inv.npz runs/s34/views_chal.npz runs/s34/views_rand.npz)
for step in "${steps[@]}"; do
    case $step in
    network)
        python scripts/calibrate_attention.py network-fit --positive-weight 2 --network-out $net \
            > $out/network_fit_w2.txt 2>&1 ;;
    fit)
        python scripts/calibrate_attention.py verifier-fit --own-layouts --loop-views "${views[@]}" \
            --threshold-on first-views --network $net --model-json $model > $out/fit_w2.txt 2>&1 ;;
    exposure)
        python docs/experiments_s11/exposure_wide.py report --seed-base 72100 --count-scale 2 --model $model \
            --network $net > $out/exposure72100_w2.txt 2>&1 || true ;;
    *) echo "unknown step $step" >&2; exit 2 ;;
    esac
done
echo "run_weight: ${steps[*]} done"
