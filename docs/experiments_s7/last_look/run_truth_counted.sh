#!/bin/bash
# seventh session: the 'last look' on tuning seeds (70000+) and tuning palettes; base = shipped, a = (3.0, 2.5), b = (2.5, 3.0)
cd /work/main; source scripts/env.sh >/dev/null 2>&1
v=$1; d=runs/s7_lastlook/$v; mkdir -p $d
if [ "$v" != base ]; then export PYTHONPATH=/tmp/s7/wt_$v/src/impurity_attention:$PYTHONPATH; fi
python -c "from impurity_attention.core.attention import AttentionParams as P; p=P(); print('last look', p.last_look_contrast, p.last_look_color_contrast)"
python -m impurity_learning.eval_cli --methods ours --rules cell --episodes 20 --palette-groups default tuning \
  --group-episodes 24 --seed-base 70000 --perception-scenes 1 --jobs 1 --no-progress --no-resume \
  --markdown $d/results.md --chart $d/results.png --json $d/results.json --readme $d/README.md \
  --generalisation $d/generalisation.md --generalisation-chart $d/gen.png --generalisation-scenes $d/scenes.png
