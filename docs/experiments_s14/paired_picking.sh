#!/usr/bin/env bash
# Paired picking: the shipped cell and a candidate on the same seeds, truth-counted (push_out.py run),
# invisible / challenging / random 100 episodes each (--start 0 / 100 / 200 of the common options' seed base),
# the two arms side by side (--jobs 1 each, 2 cores). Writes DIR/NAME_shipped/ and DIR/NAME_ARM/ (a .jsonl per
# scenario), their logs DIR/NAME_shipped.log and DIR/NAME_ARM.log, and DIR/NAME_paired.txt: push_out.py paired
# on the two directories (pooled over the scenarios), then per scenario.
# Usage (from the repository root, after `source scripts/env.sh`):
#   docs/experiments_s14/paired_picking.sh DIR NAME ARM [ARM's options ...] -- COMMON OPTIONS ...
# e.g. docs/experiments_s14/paired_picking.sh runs/s36 picking c2 --verifier runs/s36/verifier_c2.json -- \
#          --seed-base SEED --palette blocks   (SEED: a block registered in splits.TUNING_SEED_BLOCKS)
set -euo pipefail
[ $# -ge 4 ] || { echo "usage: $0 DIR NAME ARM [ARM's options ...] -- COMMON OPTIONS ..." >&2; exit 2; }
dir=$1 name=$2 candidate=$3
shift 3
extra=()
while [ $# -gt 0 ] && [ "$1" != -- ]; do extra+=("$1"); shift; done
[ $# -gt 0 ] || { echo "$0: no -- before the common options" >&2; exit 2; }
shift
push_out=docs/experiments_s14/push_out.py
pids=()
for arm in shipped "$candidate"; do
    options=()
    [ "$arm" = "$candidate" ] && options=("${extra[@]}")
    out=$dir/${name}_$arm
    mkdir -p "$out"
    (python $push_out run invisible 100 "$out/invisible.jsonl" "$@" --jobs 1 "${options[@]}"
     python $push_out run challenging 100 "$out/challenging.jsonl" --start 100 "$@" --jobs 1 "${options[@]}"
     python $push_out run random 100 "$out/random.jsonl" --start 200 "$@" --jobs 1 "${options[@]}") \
        > "$dir/${name}_$arm.log" 2>&1 &
    pids+=($!)
done
for pid in "${pids[@]}"; do wait "$pid"; done  # an arm that failed fails the script (see its log)
{
    python $push_out paired "$dir/${name}_shipped" "$dir/${name}_$candidate"
    for scenario in invisible challenging random; do
        python $push_out paired "$dir/${name}_shipped/$scenario.jsonl" "$dir/${name}_$candidate/$scenario.jsonl"
    done
} > "$dir/${name}_paired.txt" 2>&1
