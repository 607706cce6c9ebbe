#!/bin/bash
# Issue 17: measure the held-out set once with the shipped attention and network (only measured, never tuned
# on): Ours under the `cell` and `none` rules presets (or those of $RULES) on the default palette (--episodes
# per scenario) and on the held-out group (splits.held_out_palettes, cycled: GROUP_EPISODES per scenario), on
# evaluation seeds fixed before the set was rendered. Writes everything into OUT (nothing in README or docs/).
#
#     scripts/run_heldout.sh OUT SEED_BASE GROUP_EPISODES [EPISODES [PALETTE_OFFSET]]
#     scripts/run_heldout.sh runs/s13/heldout8 902900000 100     # the eighth set: its first 100 palettes
#     scripts/run_heldout.sh runs/s14/heldout8b 904900000 100 20 100   # its other 100, on seeds of their own
#     RULES=cell scripts/run_heldout.sh ...   # the rules presets measured (default: "cell none")
#
# The earlier sets' runs (docs/experiments_s*/run_heldout*.sh) call this script with their arguments.
# OUT is taken relative to the caller's directory; an existing OUT's results are replaced (--no-resume).
set -euo pipefail
usage() { sed -n 2,13p "$0" >&2; exit 2; }
[ $# -ge 3 ] || usage
for number in "$2" "$3" "${4:-20}" "${5:-0}"; do
  [[ $number =~ ^[0-9]+$ ]] || { echo "run_heldout.sh: '$number' is not a whole number" >&2; usage; }
done
read -r -a rules <<< "${RULES:-cell none}"
out=$(realpath -m -- "$1") seed_base=$2 group_episodes=$3 episodes=${4:-20} palette_offset=${5:-0}
cd "$(dirname "$0")/.."
set +u
source scripts/env.sh >/dev/null || { echo "run_heldout.sh: scripts/env.sh failed (run make setup)" >&2; exit 1; }
set -u
python -c "import sys; from impurity_policy.core.rules import PRESETS; bad = [r for r in sys.argv[1:] if r not in PRESETS]; \
sys.exit(f'run_heldout.sh: RULES={sys.argv[1:]} names no preset or an unknown one {bad}; known: {sorted(PRESETS)}' \
if bad or len(sys.argv) < 2 else 0)" "${rules[@]}"
mkdir -p "$out/images"
date; git rev-parse HEAD
python -c "from impurity_attention.core.attention import AttentionParams as A; a = A(); print('decision', a.decision, 'verifier_last_look', a.verifier_last_look, 'verifier_clipped_threshold', a.verifier_clipped_threshold); from impurity_attention.core import verifier as v; print('verifier features', len(v.FEATURES), v.default_verifier().provenance)"
python -c "from impurity_policy.core.rules import PRESETS, RuleParams; print('rules cell', ', '.join(PRESETS['cell'])); print(RuleParams())"
cp README.md "$out/README.md"
python -m impurity_learning.eval_cli --methods ours --rules "${rules[@]}" --episodes "$episodes" \
  --palette-groups default held_out --group-episodes "$group_episodes" --group-palette-offset "$palette_offset" \
  --seed-base "$seed_base" \
  --markdown "$out/results.md" --chart "$out/results.png" --json "$out/results.json" --readme "$out/README.md" \
  --generalisation "$out/generalisation.md" --generalisation-chart "$out/images/generalisation.png" \
  --generalisation-scenes "$out/images/generalisation_scenes.png" --perception-scenes 1 --no-progress \
  --no-resume --jobs 2
date
