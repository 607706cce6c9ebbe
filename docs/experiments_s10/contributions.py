"""Tenth session, tuning data only: each verifier term on the impurity regions of the 22 last views that ended
with a target left (final_views.py), as coef * (clip(x) - mean) / scale.

    python docs/experiments_s10/contributions.py
"""
import sys; sys.path.insert(0, "docs/experiments_s10")
import numpy as np
import final_views as fv
from impurity_attention.core.attention import AttentionParams, sanitize, scene_maps, salient_regions
from impurity_attention.core.verifier import candidate_features, default_verifier, FEATURES
m = default_verifier()
rows, records = fv.load()
params = AttentionParams()
def contribs(record):
    color, height = sanitize(record.color, record.height)
    objects = height > params.density.occupied_height
    sal, con = scene_maps(color, objects, params)
    regions = salient_regions(sal, objects, params)
    out = []
    for region, f in candidate_features(color, height, objects, con, regions):
        if f is None: continue
        on = bool(np.any(region.mask & record.visible_target_cells))
        x = np.clip(f, m.low, m.high)
        c = np.array(m.coef) * (x - np.array(m.mean)) / np.array(m.scale)
        out.append((on, float(m.probability(f[None])[0]), c, f))
    return out
left = [(r, rec) for r, rec in zip(rows, records) if r["termination"] == "no_target_or_cluster_left" and r["left"] > 0]
print("features:", FEATURES)
C = []
for r, rec in left:
    for on, p, c, f in contribs(rec):
        if on:
            C.append(c); print(f"{r['palette']:11s} {r['scenario'][:5]} p {p:.2f} ", " ".join(f"{v:+.1f}" for v in c), " obj_share %.3f regions %.2f" % (np.exp(f[-1]), f[-3]))
print("mean contribution on the missed targets:", " ".join(f"{n[:10]}={v:+.2f}" for n, v in zip(FEATURES, np.mean(C, 0))))
