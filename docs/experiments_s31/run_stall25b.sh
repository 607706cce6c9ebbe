#!/usr/bin/env bash
# Thirty-first session (docs/experiments.md, thirty-first section; criterion written there before this ran): the
# stall look at 0.25 (push_out.py --stall 5 0.25) against the shipped cell on more episodes than the thirtieth
# session's test, read with make eval's per-episode grasp success. Tuning palettes (the named ones and random-500
# ... 599), fresh tuning seeds registered in splits.TUNING_SEED_BLOCKS: challenging 11 400-11 799, invisible
# 11 800-11 999 (--start 400), random 10 514-10 613 (--seed-base 10514). Each part runs the shipped cell on every
# seed, then the stall look only where it can act (episodes with 5 or more OCCLUDED_REGION decisions in a row:
# `push_out.py candidates`), plus the first 10 other seeds as a check that those play alike; `paired --fill`
# counts the rest as alike. Usage, from the repository root after `source scripts/env.sh`:
#     docs/experiments_s31/run_stall25b.sh            (both cores; the shipped arm first, part by part)
set -euo pipefail
out=runs/s31/stall25b
mkdir -p "$out"
common=(--random-from 500 --random-palettes 100 --jobs 2)
part() {  # scenario episodes start seed_base
    local scenario=$1 episodes=$2 start=$3 base=$4
    python docs/experiments_s14/push_out.py run "$scenario" "$episodes" "$out/shipped_$scenario.jsonl" \
        --start "$start" --seed-base "$base" "${common[@]}"
    read -r -a can <<< "$(python docs/experiments_s14/push_out.py candidates "$out/shipped_$scenario.jsonl" 5 \
        --seed-base "$base")"
    read -r -a check <<< "$(python -c "import sys; c = set(map(int, sys.argv[4:])); \
print(' '.join([str(k) for k in range(int(sys.argv[1]), int(sys.argv[1]) + int(sys.argv[2])) if k not in c][:10]))" \
        "$start" "$episodes" x "${can[@]}")"
    echo "$scenario: ${#can[@]} candidates, check ${check[*]}"
    python docs/experiments_s14/push_out.py run "$scenario" 0 "$out/stall_$scenario.jsonl" --seed-base "$base" \
        --only "${can[@]}" "${check[@]}" --stall 5 0.25 "${common[@]}"
}
part challenging 400 0 11400
part invisible 200 400 11400
part random 100 0 10514
