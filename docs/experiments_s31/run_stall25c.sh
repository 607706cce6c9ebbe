#!/usr/bin/env bash
# Thirty-first session, test B (docs/experiments.md, thirty-first section; criterion written there before this
# ran): the stall look at 0.25 (push_out.py --stall 5 0.25) against the shipped cell on fresh challenging tuning
# seeds 12 300-12 699 and tuning palettes named + random-600 ... 699, read for completion. As run_stall25b.sh:
# the shipped cell on every seed, the stall look where it can act plus 10 check seeds.
#     docs/experiments_s31/run_stall25c.sh            (both cores)
set -euo pipefail
out=runs/s31/stall25c
mkdir -p "$out"
common=(--random-from 600 --random-palettes 100 --jobs 2)
base=12300
python docs/experiments_s14/push_out.py run challenging 400 "$out/shipped_challenging.jsonl" --seed-base "$base" \
    "${common[@]}"
read -r -a can <<< "$(python docs/experiments_s14/push_out.py candidates "$out/shipped_challenging.jsonl" 5 \
    --seed-base "$base")"
read -r -a check <<< "$(python -c "import sys; c = set(map(int, sys.argv[2:])); \
print(' '.join([str(k) for k in range(int(sys.argv[1])) if k not in c][:10]))" 400 "${can[@]}")"
echo "challenging: ${#can[@]} candidates, check ${check[*]}"
python docs/experiments_s14/push_out.py run challenging 0 "$out/stall_challenging.jsonl" --seed-base "$base" \
    --only "${can[@]}" "${check[@]}" --stall 5 0.25 "${common[@]}"
