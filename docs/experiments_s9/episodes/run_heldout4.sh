#!/bin/bash
# issue 17, ninth session: the fourth held-out set measured once with the shipped attention and network, on
# evaluation seeds fixed before it was rendered (900500000 + k). The held-out group cycles through all 28
# palettes (generalisation.group_palettes), 56 episodes per scenario: each palette twice per scenario.
cd /work/main; source scripts/env.sh >/dev/null 2>&1
d=runs/s9/heldout4; mkdir -p $d/images
date; git rev-parse HEAD
python -c "from impurity_attention.core import verifier as v; print('verifier features', len(v.FEATURES))"
cp README.md $d/README.md
python -m impurity_learning.eval_cli --methods ours --rules cell none --episodes 20 --palette-groups default held_out \
  --group-episodes 56 --seed-base 900500000 --markdown $d/results.md --chart $d/results.png --json $d/results.json \
  --readme $d/README.md --generalisation $d/generalisation.md --generalisation-chart $d/images/generalisation.png \
  --generalisation-scenes $d/images/generalisation_scenes.png --perception-scenes 1 --no-progress --no-resume --jobs 2
date
