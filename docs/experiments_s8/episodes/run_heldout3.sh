#!/bin/bash
# issue 17, eighth session: the third held-out set measured once with the region verifier (shipped network),
# on the seventh session's seeds (900400000 + k), so each episode pairs with the rule's in docs/heldout3/
cd /work/main; source scripts/env.sh >/dev/null 2>&1
d=runs/s8_heldout3; mkdir -p $d/images
date; git rev-parse HEAD
python -c "from impurity_attention.core.attention import AttentionParams as P; print('decision', P().decision)"
cp README.md $d/README.md
python -m impurity_learning.eval_cli --methods ours --rules cell none --episodes 20 --palette-groups default held_out \
  --group-episodes 48 --seed-base 900400000 --markdown $d/results.md --chart $d/results.png --json $d/results.json \
  --readme $d/README.md --generalisation $d/generalisation.md --generalisation-chart $d/images/generalisation.png \
  --generalisation-scenes $d/images/generalisation_scenes.png --perception-scenes 1 --no-progress --no-resume
date
