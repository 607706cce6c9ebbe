#!/usr/bin/env bash
# Thirty-fourth session (docs/experiments.md): the verifier refitted with the impurity network, and every
# check of the criterion written there, in order. From the repository root of a tree with the network's code
# after `source scripts/env.sh`; writes runs/s34/. The candidate network (runs/impurity_net.pt) is passed to
# every tool that reads it (--network; since the thirty-seventh session, when the network shipped, nothing is
# copied over the shipped one in src/impurity_attention/checkpoints/).
# Usage: docs/experiments_s34/run_refit.sh [step ...] (steps: network views fit check exposure specs picking
# picking_default; default all). picking_default: the thirty-fifth session's default-palette picking test.
set -euo pipefail
mkdir -p runs/s34
steps=("${@:-network views fit check exposure specs picking picking_default}")
steps=(${steps[*]})
ca=scripts/calibrate_attention.py
lv=docs/experiments_s17/loop_views.py
model=runs/s34/verifier_net.json
net=runs/impurity_net.pt
views=(runs/s34/views_inv.npz runs/s34/views_chal.npz runs/s34/views_rand.npz)
last_look() { sed -n 's/^chosen t = //p' runs/s34/last_look.txt; }
# paired_picking NAME COMMON OPTIONS...: docs/experiments_s14/paired_picking.sh (since the thirty-sixth
# session; it adds the pooled comparison at the top of runs/s34/NAME_paired.txt), the arm net with the refit's
# model and last look; writes runs/s34/NAME_{shipped,net}/.
paired_picking() {
    local name=$1
    shift
    bash docs/experiments_s14/paired_picking.sh runs/s34 "$name" net --verifier $model --network $net \
        --last-look "$(last_look)" -- "$@"
}
for step in "${steps[@]}"; do
    case $step in
    network)
        python $ca network-fit > runs/s34/network_fit.txt 2>&1
        python docs/experiments_s34/compare_networks.py runs/impurity_net.pt /work/main/runs/s33/cnn_h4.pt \
            > runs/s34/compare_networks.txt 2>&1 ;;
    views)
        [ -f runs/s34/views_inv.npz ] || python $lv collect invisible 160 runs/s34/views_inv.npz
        [ -f runs/s34/views_chal.npz ] || python $lv collect challenging 80 runs/s34/views_chal.npz --start 200
        [ -f runs/s34/views_rand.npz ] || python $lv collect random 80 runs/s34/views_rand.npz --start 400
        python $lv subset even runs/s34/views_even.npz "${views[@]}"
        python $lv subset odd runs/s34/views_odd.npz "${views[@]}" ;;
    fit)
        python $ca verifier-fit --own-layouts --loop-views "${views[@]}" --threshold-on first-views \
            --network runs/impurity_net.pt --model-json $model > runs/s34/fit_net.txt 2>&1
        python $ca verifier-fit --own-layouts --loop-views runs/s34/views_even.npz --threshold-on first-views \
            --network runs/impurity_net.pt --model-json runs/s34/verifier_even.json --no-check \
            > runs/s34/fit_even.txt 2>&1
        python docs/experiments_s21/last_look.py runs/s34/verifier_even.json runs/s34/views_odd.npz \
            > runs/s34/last_look.txt 2>&1 ;;
    check)
        python docs/experiments_s33/check_palettes.py $model --last-look "$(last_look)" --network $net \
            > runs/s34/check_palettes.txt 2>runs/s34/check.err ;;
    exposure)
        python docs/experiments_s11/exposure_wide.py report --seed-base 72100 --count-scale 2 --model $model \
            --network $net --last-look "$(last_look)" > runs/s34/exposure72100_net.txt 2>&1 ;;
    specs)
        python docs/experiments_s21/with_model.py $model --last-look "$(last_look)" --network $net \
            tests/unit/impurity_attention \
            > runs/s34/specs.txt 2>&1 || true ;;
    picking)
        paired_picking picking --seed-base 13600 --random-from 600 --random-only --random-palettes 100 ;;
    picking_default)
        paired_picking picking_default --seed-base 14300 --palette blocks ;;
    *) echo "unknown step $step" >&2; exit 2 ;;
    esac
done
echo "run_refit: ${steps[*]} done"
