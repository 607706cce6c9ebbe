"""Seventh session, tuning data only: a taught product model instead of saliency. Per palette, one clean
view (the invisible scene without impurity) is the teach-in; its object cells' colours make a histogram
of BINS per channel (smoothed over neighbours); a cell is off the product where the density is below the
teach-in's own Q quantile; the largest connected off-product component of at least AREA px (after a 3x3
opening) is the target. Found = it touches a visible target; false TARGET = any such component in a
scene without impurity. From the repository root after `source scripts/env.sh`:

    python docs/experiments_s7/teach.py tuning BINS Q AREA      # e.g. tuning 16 0.002 30
"""
import sys, collections
sys.path.insert(0, "scripts")
import numpy as np, cv2
import calibrate_attention as ca
from impurity_attention.core.attention import AttentionParams, attend, salient_regions, scene_saliency
BINS = int(sys.argv[2]) if len(sys.argv) > 2 else 16
Q = float(sys.argv[3]) if len(sys.argv) > 3 else 0.01
AREA = int(sys.argv[4]) if len(sys.argv) > 4 else 30
split = sys.argv[1]
recs = ca.collect_palettes(split)
by = collections.defaultdict(list)
for r in recs: by[r.palette].append(r)

def model(colors):
    h, _ = np.histogramdd(colors, bins=(BINS,)*3, range=[(0, 256)]*3)
    h = h / h.sum()
    # smooth: a 3x3x3 box of neighbours
    from scipy.ndimage import uniform_filter
    hs = uniform_filter(h, size=3, mode="constant")
    return hs

def density(hs, img):
    idx = (img.astype(int) * BINS) // 256
    return hs[idx[..., 0], idx[..., 1], idx[..., 2]]

tot = collections.Counter(); found = collections.Counter(); fals = collections.Counter(); clean = collections.Counter()
for pal, rs in by.items():
    teach = [r for r in rs if r.scenario == "invisible" and r.num_targets == 0]
    if not teach: continue
    t = teach[0]
    obj = t.height > 0.01
    hs = model(t.color[obj].reshape(-1, 3).astype(float))
    dens_t = density(hs, t.color)[obj]
    tau = np.quantile(dens_t, Q)
    for r in rs:
        if r is t: continue
        cat = r.category()
        if cat not in ("visible", "no_impurity"): continue
        o = r.height > 0.01
        anom = (density(hs, r.color) < tau) & o
        anom = cv2.morphologyEx(anom.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)) > 0
        n, lab, st, _ = cv2.connectedComponentsWithStats(anom.astype(np.uint8), connectivity=8)
        comps = [i for i in range(1, n) if st[i, cv2.CC_STAT_AREA] >= AREA]
        if cat == "visible":
            tot[pal] += 1
            if comps:
                best = max(comps, key=lambda i: st[i, cv2.CC_STAT_AREA])
                if np.any((lab == best) & r.visible_target_cells): found[pal] += 1
        else:
            clean[pal] += 1
            if comps: fals[pal] += 1
T, F, C, FA = sum(tot.values()), sum(found.values()), sum(clean.values()), sum(fals.values())
print(f"{split} bins {BINS} q {Q} area {AREA}: found {F}/{T} = {100*F/T:.1f} %, false TARGET {FA}/{C} = {100*FA/C:.1f} %")
worst = sorted(tot, key=lambda p: found[p] / tot[p])[:8]
print("  worst:", [(p, found[p], tot[p], fals[p]) for p in worst])
