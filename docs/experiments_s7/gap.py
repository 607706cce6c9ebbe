"""Seventh session, tuning data only: the tuning palettes' visible scenes whose impurity is colour-separable
(evaluation.colour_separable) and that the shipped rule misses, with attention's reason.

    python docs/experiments_s7/gap.py
"""
import sys, collections
sys.path.insert(0, "scripts")
import numpy as np, cv2
import calibrate_attention as ca
from impurity_attention.core import evaluation
from impurity_attention.core.attention import AttentionParams, attend
recs = ca.collect_palettes("tuning")
p = AttentionParams()
rows = []
for r in recs:
    if r.category() != "visible": continue
    sep = evaluation.colour_separable(r)
    out = attend(r.color, r.height, p)
    v = evaluation.judge(r, out)
    if sep and not v.success:
        best = out.regions[0] if out.regions else None
        on = best is not None and bool(np.any(best.mask & r.visible_target_cells))
        obj = r.height > 0.01
        prodI = r.color[obj & ~np.isin(r.labels, list(r.target_ids))].mean()
        tI = r.color[r.visible_target_cells & obj].mean()
        rows.append((r.palette, r.scenario, r.seed, out.mode.name, on, round(prodI), round(tI), int((r.visible_target_cells & obj).sum()), out.reason[:90]))
print(len(rows))
for x in rows: print(x)
