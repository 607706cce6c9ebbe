#!/usr/bin/env bash
# Thirty-sixth session (docs/experiments.md): the thirty-fifth session's candidate (the impurity network and the
# verifier refitted with it, docs/experiments_s35/) with its three thresholds matched to the shipped cell's
# (match_thresholds.py), and every check of the criterion written there, in order. From the repository root
# after `source scripts/env.sh`; writes runs/s36/. The candidate network is passed to every tool that reads it
# (--network; the run itself, at c251c96, copied it where attention reads the shipped one, which the thirty-
# seventh session's tools made unnecessary and its shipping of the network made harmful).
# Usage: docs/experiments_s36/run_match.sh [step ...] (steps: match check exposure specs picking
# picking_default; default all).
set -euo pipefail
out=runs/s36
mkdir -p $out
net=docs/experiments_s35/impurity_net.pt
steps=("${@:-match check exposure specs picking picking_default}")
steps=(${steps[*]})
model=$out/verifier_c2.json
threshold() { sed -n "s/^$1 //p" $out/thresholds.txt; }
# paired_picking NAME COMMON OPTIONS...: docs/experiments_s14/paired_picking.sh, the arm c2 with the matched
# model, last look and stall look; writes $out/NAME_{shipped,c2}/ and $out/NAME_paired.txt.
paired_picking() {
    local name=$1
    shift
    bash docs/experiments_s14/paired_picking.sh $out "$name" c2 --verifier $model --network $net \
        --last-look "$(threshold last_look)" --stall-look-threshold "$(threshold stall_look)" -- "$@"
}
for step in "${steps[@]}"; do
    case $step in
    match)
        python docs/experiments_s36/match_thresholds.py docs/experiments_s35/verifier_net.json \
            $net runs/s34/views_inv.npz runs/s34/views_chal.npz \
            runs/s34/views_rand.npz --out $model --thresholds $out/thresholds.txt --check \
            > $out/match.txt 2>&1 ;;
    check)
        python docs/experiments_s33/check_palettes.py $model --last-look "$(threshold last_look)" \
            --network $net > $out/check_palettes.txt 2>$out/check.err ;;
    exposure)
        python docs/experiments_s11/exposure_wide.py report --seed-base 72100 --count-scale 2 --model $model \
            --network $net --last-look "$(threshold last_look)" > $out/exposure72100_c2.txt 2>&1 ;;
    specs)
        python docs/experiments_s21/with_model.py $model --last-look "$(threshold last_look)" --network $net \
            tests/unit/impurity_attention > $out/specs.txt 2>&1 || true
        python docs/experiments_s36/spec_with_network.py $model $net \
            >> $out/specs.txt 2>&1 || true ;;
    picking)
        paired_picking picking --seed-base 14600 --random-from 600 --random-only --random-palettes 100 ;;
    picking_default)
        paired_picking picking_default --seed-base 15300 --palette blocks ;;
    *) echo "unknown step $step" >&2; exit 2 ;;
    esac
done
echo "run_match: ${steps[*]} done"
