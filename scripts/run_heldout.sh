#!/bin/bash
# Issue 17: measure the held-out set once with the shipped attention and network (only measured, never tuned
# on): Ours under the `cell` and `none` rules presets on the default palette (--episodes per scenario) and on
# the held-out group (splits.held_out_palettes, cycled: GROUP_EPISODES per scenario), on evaluation seeds fixed
# before the set was rendered. Writes everything into OUT (nothing in README or docs/).
#
#     scripts/run_heldout.sh OUT SEED_BASE GROUP_EPISODES [EPISODES]
#     scripts/run_heldout.sh runs/s12/heldout7 900900000 60      # the seventh set: each palette once
#
# The earlier sets' runs are kept as they ran in docs/experiments_s*/run_heldout*.sh.
set -euo pipefail
if [ $# -lt 3 ]; then sed -n 2,9p "$0"; exit 2; fi
out=$1 seed_base=$2 group_episodes=$3 episodes=${4:-20}
cd "$(dirname "$0")/.."
set +u; source scripts/env.sh >/dev/null 2>&1; set -u
mkdir -p "$out/images"
date; git rev-parse HEAD
python -c "from impurity_attention.core.attention import AttentionParams as A; a = A(); print('verifier_last_look', a.verifier_last_look, 'verifier_clipped_threshold', a.verifier_clipped_threshold); from impurity_attention.core.verifier import default_verifier as v; print(v().provenance)"
cp README.md "$out/README.md"
python -m impurity_learning.eval_cli --methods ours --rules cell none --episodes "$episodes" \
  --palette-groups default held_out --group-episodes "$group_episodes" --seed-base "$seed_base" \
  --markdown "$out/results.md" --chart "$out/results.png" --json "$out/results.json" --readme "$out/README.md" \
  --generalisation "$out/generalisation.md" --generalisation-chart "$out/images/generalisation.png" \
  --generalisation-scenes "$out/images/generalisation_scenes.png" --perception-scenes 1 --no-progress \
  --no-resume --jobs 2
date
