"""Seventh session, tuning data only: a per-cell colour feature for the best salient region, the share of its
cells whose colour is rare among the other object cells (histogram density below their own 1 % quantile,
as evaluation.colour_separable but without the truth). Writes the rows (score, on target, Mahalanobis
colour contrast, rare share) of rule-sweep's scenes to runs/s7_rare_rows.pkl; rare_grid.py reads them.

    python docs/experiments_s7/rare.py && python docs/experiments_s7/rare_grid.py
"""
import sys, pickle
sys.path.insert(0, "scripts")
import numpy as np
import calibrate_attention as ca
from impurity_attention.core.evaluation import off_colours
from impurity_attention.core.attention import AttentionParams, salient_regions, scene_saliency, region_color_contrast
def rare_share(color, region, objects):
    others = objects & ~region
    if not others.any(): return 1.0
    return float(np.mean(off_colours(color, others)[region]))
params = AttentionParams()
records, _ = ca.rule_sweep_records()
vis, clean = [], []
for r in records:
    cat = r.category()
    if cat not in ("visible", "no_impurity", "invisible"): continue
    obj = r.height > params.density.occupied_height
    regs = salient_regions(scene_saliency(r.color, obj, params), obj, params)
    b = regs[0] if regs else None
    if b is None:
        row = (0, False, 0, 0)
    else:
        row = (b.score, bool(np.any(b.mask & r.visible_target_cells)), region_color_contrast(r.color, obj, b, params), rare_share(r.color, b.mask, obj))
    (vis if cat == "visible" else clean).append(row)
vis, clean = np.array(vis, float), np.array(clean, float)
pickle.dump((vis, clean), open("runs/s7_rare_rows.pkl", "wb"))
print(len(vis), len(clean))
