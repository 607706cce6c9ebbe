#!/bin/bash
# eighth session: the region verifier on tuning seeds (70000+) and tuning palettes, truth-counted.
# base = shipped rule; v = a git worktree at /tmp/s8/wt_v with AttentionParams.decision = "verifier" on PYTHONPATH
cd /work/main; source scripts/env.sh >/dev/null 2>&1
v=$1; d=runs/s8_verifier/$v; mkdir -p $d
if [ "$v" != base ]; then export PYTHONPATH=/tmp/s8/wt_$v/src/impurity_attention:$PYTHONPATH; fi
python -c "from impurity_attention.core.attention import AttentionParams as P; print('decision', P().decision)"
python -m impurity_learning.eval_cli --methods ours --rules cell --episodes 20 --palette-groups default tuning \
  --group-episodes 48 --seed-base 70000 --perception-scenes 1 --jobs 1 --no-progress --no-resume \
  --markdown $d/results.md --chart $d/results.png --json $d/results.json --readme $d/README.md \
  --generalisation $d/generalisation.md --generalisation-chart $d/gen.png --generalisation-scenes $d/scenes.png
