"""Eighth session, tuning data only: features of the top salient regions of rule-sweep's scenes, for a
learned region verifier (verifier_cv.py). One row per (scene, region rank < TOP):
scene index, palette, category, rank, on target, then FEATURES. Written to runs/s8_verifier_rows.npz.

    python docs/experiments_s8/verifier_rows.py [--split tuning|acceptance|retired]
"""
import sys, argparse
sys.path.insert(0, "scripts")
from multiprocessing import Pool
import numpy as np, cv2
import calibrate_attention as ca
from impurity_attention.core.attention import (AttentionParams, salient_regions, region_color_contrast,
                                               saliency_input, relative_saliency, chroma)
from impurity_attention.core.saliency import vocus2, opponent_colour, CHANNELS
from impurity_attention.core.evaluation import off_colours
import dataclasses

TOP = 3
P = AttentionParams()
P_CORR = dataclasses.replace(P, color_shading=0.1, color_saturation=250.0)
FEATURES = ["log_score", "log_peak", "log_colour", "log_colour_corr", "rel_I", "rel_RG", "rel_BY",
            "log_area", "rank", "score_over_best", "best_over_next", "rare_share", "chroma_dist",
            "light_diff", "log_regions", "area_share", "height_rel", "height_std", "solidity",
            "bright_share", "dark_share"]


def features(color, height):
    objects = height > P.density.occupied_height
    image = saliency_input(color, objects, P.background)
    maps = vocus2(image, P.saliency, keep_features=True, colour_space="chromaticity")
    sal = relative_saliency(maps.conspicuity, objects, P.lightness_weight)
    regions = salient_regions(sal, objects, P)
    rows = []
    if not regions:
        return rows, []
    ch = chroma(color)
    logI = np.log(np.maximum(opponent_colour(color)[..., 0], 0.05))
    hmed = float(np.median(height[objects]))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
    for k, reg in enumerate(regions[:TOP]):
        m = reg.mask
        prod = objects & ~(cv2.dilate(m.astype(np.uint8), kernel) > 0)
        if not prod.any():
            prod = objects & ~m
        rel = []
        for name in CHANNELS:
            plane = maps.conspicuity[name]
            lvl = max(float(plane[prod].mean()) if prod.any() else 1e-4, 1e-4)
            rel.append(float(plane[m].mean() / lvl))
        c_plain = min(region_color_contrast(color, objects, reg, P), 100.0)
        c_corr = min(region_color_contrast(color, objects, reg, P_CORR), 100.0)
        rare = float(np.mean(off_colours(color, objects & ~m)[m])) if (objects & ~m).any() else 1.0
        if prod.any():
            pc = ch[prod]
            med = np.median(pc, axis=0)
            mad = np.median(np.linalg.norm(pc - med, axis=1)) + 1e-3
            cd = float(np.linalg.norm(np.median(ch[m], axis=0) - med) / mad)
            pl = logI[prod]
            ld = float((np.median(logI[m]) - np.median(pl)) / (np.std(pl) + 1e-3))
            bright = float(np.mean(logI[m] > np.quantile(pl, 0.99)))
            dark = float(np.mean(logI[m] < np.quantile(pl, 0.01)))
        else:
            cd = ld = bright = dark = 0.0
        cnts, _ = cv2.findContours(m.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        hull = cv2.convexHull(np.vstack(cnts))
        solidity = reg.area / max(cv2.contourArea(hull), 1.0)
        nxt = regions[1].score if len(regions) > 1 else regions[0].score / 2
        rows.append([np.log(reg.score), np.log(reg.peak), np.log1p(c_plain), np.log1p(c_corr),
                     *np.log(np.maximum(rel, 1e-3)), np.log(reg.area), k, reg.score / regions[0].score,
                     np.log(regions[0].score / max(nxt, 1e-6)), rare, np.log1p(cd), ld,
                     np.log(len(regions)), reg.area / objects.sum(), float(height[m].mean()) - hmed,
                     float(height[m].std()), solidity, bright, dark])
    return rows, [r.mask for r in regions[:TOP]]


def one(args):
    i, r = args
    cat = r.category()
    if cat not in ("visible", "no_impurity", "invisible"):
        return []
    rows, masks = features(r.color, r.height)
    out = []
    for k, (row, m) in enumerate(zip(rows, masks)):
        on = bool(np.any(m & r.visible_target_cells)) if cat == "visible" else False
        out.append((i, r.palette or "blocks", cat, k, on, row))
    if not rows:
        out.append((i, r.palette or "blocks", cat, -1, False, [0.0] * len(FEATURES)))
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--split", default="tuning")
    a = ap.parse_args()
    if a.split == "tuning":
        records, _ = ca.rule_sweep_records()
    else:
        records = ca.collect_palettes(a.split)
    print(len(records), "scenes", flush=True)
    with Pool(2) as pool:
        res = pool.map(one, list(enumerate(records)), chunksize=8)
    flat = [x for r in res for x in r]
    scene = np.array([x[0] for x in flat]); palette = np.array([x[1] for x in flat])
    cat = np.array([x[2] for x in flat]); rank = np.array([x[3] for x in flat])
    on = np.array([x[4] for x in flat]); X = np.array([x[5] for x in flat], float)
    np.savez_compressed(f"runs/s8_verifier_rows_{a.split}.npz", scene=scene, palette=palette, cat=cat,
                        rank=rank, on=on, X=X, features=np.array(FEATURES))
    print(len(flat), "rows;", len(set(scene)), "scenes")
