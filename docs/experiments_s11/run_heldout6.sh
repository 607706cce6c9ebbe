#!/bin/bash
# issue 17, eleventh session: the sixth held-out set measured once with the shipped attention and network, on
# evaluation seeds fixed before it was rendered (900700000 + k). The held-out group cycles through all 28
# palettes (generalisation.group_palettes), 56 episodes per scenario: each palette twice per scenario.
cd /work/main; source scripts/env.sh >/dev/null 2>&1
d=runs/s11/heldout6; mkdir -p $d/images
date; git rev-parse HEAD
python -c "from impurity_attention.core.attention import AttentionParams as A; print('verifier_last_look', A().verifier_last_look); from impurity_attention.core.verifier import default_verifier as v; print(v().provenance)"
cp README.md $d/README.md
python -m impurity_learning.eval_cli --methods ours --rules cell none --episodes 20 --palette-groups default held_out \
  --group-episodes 56 --seed-base 900700000 --markdown $d/results.md --chart $d/results.png --json $d/results.json \
  --readme $d/README.md --generalisation $d/generalisation.md --generalisation-chart $d/images/generalisation.png \
  --generalisation-scenes $d/images/generalisation_scenes.png --perception-scenes 1 --no-progress --no-resume --jobs 2
date
