#!/bin/bash
# ninth session: the twelve-feature verifier against the eighth session's, on tuning seeds (70000+) and tuning
# palettes, truth-counted. v1 = a git worktree at /tmp/s9/wt_v1 of 2410b25 (the eighth session's verifier) on
# PYTHONPATH; v2 = the working tree (the refitted twelve-feature verifier; run as v2 before the lightness features
# left clipped cells out, as v2b after).
cd /work/main; source scripts/env.sh >/dev/null 2>&1
v=$1; d=runs/s9/episodes_$v; mkdir -p $d
if [ "$v" = v1 ]; then export PYTHONPATH=/tmp/s9/wt_v1/src/impurity_attention:$PYTHONPATH; fi
python -c "from impurity_attention.core import verifier as v; print('verifier features', len(v.FEATURES))"
python -m impurity_learning.eval_cli --methods ours --rules cell --episodes 20 --palette-groups default tuning \
  --group-episodes 48 --seed-base 70000 --perception-scenes 1 --jobs 1 --no-progress --no-resume \
  --markdown $d/results.md --chart $d/results.png --json $d/results.json --readme $d/README.md \
  --generalisation $d/generalisation.md --generalisation-chart $d/gen.png --generalisation-scenes $d/scenes.png
