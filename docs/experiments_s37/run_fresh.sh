#!/usr/bin/env bash
# Thirty-seventh session (docs/experiments.md): the thirty-sixth session's candidate C2 (the impurity network
# docs/experiments_s35/impurity_net.pt, the verifier docs/experiments_s36/verifier_c2.json and the three
# thresholds of docs/experiments_s36/thresholds.txt) against the shipped cell on fresh tuning data: a check set
# on fresh tuning palettes, a fresh default-palette exposure set, the unit specifications and paired picking on
# fresh seeds. From the repository root after `source scripts/env.sh`; writes runs/s37/. The candidate network
# is passed to every tool (--network); nothing is copied into the source tree.
# Usage: docs/experiments_s37/run_fresh.sh [step ...] (steps: check exposure specs picking picking_default;
# default all).
set -euo pipefail
out=runs/s37
mkdir -p $out
steps=("${@:-check exposure specs picking picking_default}")
steps=(${steps[*]})
network=docs/experiments_s35/impurity_net.pt
model=docs/experiments_s36/verifier_c2.json
threshold() { sed -n "s/^$1 //p" docs/experiments_s36/thresholds.txt; }
# paired_picking NAME COMMON OPTIONS...: docs/experiments_s14/paired_picking.sh, the arm c2 with C2's model,
# network, last look and stall look; writes $out/NAME_{shipped,c2}/ and $out/NAME_paired.txt.
paired_picking() {
    local name=$1
    shift
    bash docs/experiments_s14/paired_picking.sh $out "$name" c2 --verifier $model --network $network \
        --last-look "$(threshold last_look)" --stall-look-threshold "$(threshold stall_look)" -- "$@"
}
for step in "${steps[@]}"; do
    case $step in
    check)
        python docs/experiments_s33/check_palettes.py $model --last-look "$(threshold last_look)" \
            --network $network --random-from 2000000 --count 176 --layout-seed-base 76620 --packed \
            > $out/check_palettes.txt 2>$out/check.err ;;
    exposure)
        python docs/experiments_s11/exposure_wide.py report --seed-base 92200 --count-scale 2 --packed \
            > $out/exposure92200_shipped.txt 2>&1
        python docs/experiments_s11/exposure_wide.py report --seed-base 92200 --count-scale 2 --packed \
            --model $model --network $network --last-look "$(threshold last_look)" \
            > $out/exposure92200_c2.txt 2>&1 ;;
    specs)
        python docs/experiments_s21/with_model.py $model --last-look "$(threshold last_look)" --network $network \
            tests/unit/impurity_attention > $out/specs.txt 2>&1 || true
        python docs/experiments_s36/spec_with_network.py $model $network >> $out/specs.txt 2>&1 || true ;;
    picking)
        paired_picking picking --seed-base 16300 --random-from 2000200 --random-only --random-palettes 100 ;;
    picking_default)
        paired_picking picking_default --seed-base 17300 --palette blocks ;;
    *) echo "unknown step $step" >&2; exit 2 ;;
    esac
done
echo "run_fresh: ${steps[*]} done"
