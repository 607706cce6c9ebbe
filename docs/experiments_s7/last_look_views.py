"""Seventh session, tuning data only: first views where the shipped attention answers NONE (no target,
no heap), by category, with the best region's saliency and colour contrast: what a last look would see.

    python docs/experiments_s7/last_look_views.py
"""
import collections
import sys

import numpy as np

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402
from impurity_attention.core.attention import AttentionMode, AttentionParams, attend, region_color_contrast  # noqa: E402

params = AttentionParams()
records, _ = ca.rule_sweep_records(exposed=False)
modes = collections.Counter()
rows = []
for r in records:
    category = r.category()
    out = attend(r.color, r.height, params)
    modes[(category, out.mode.name)] += 1
    if out.mode == AttentionMode.NONE and out.regions:
        best = out.regions[0]
        objects = r.height > params.density.occupied_height
        colour = region_color_contrast(r.color, objects, best, params)
        on = bool(np.any(best.mask & r.visible_target_cells))
        rows.append((category, on, round(best.score, 2), round(colour, 2)))
for key, n in sorted(modes.items(), key=str):
    print(key, n)
for row in sorted(rows):
    print(row)
