"""Ninth session, tuning data only: per (scene, salient region of the top TOP) the shipped verifier's five
features and sixteen more, for model experiments (models.py). Sets: shared (rule-sweep's scenes: the 101
tuning palettes on ten shared layouts, the default's tuning scenes, the default at x0.5 / x2), own (the same
palettes on layouts of their own, seeds 20000+), fresh (tuning palettes random-96 ... 191 on layouts of their
own: never used to choose anything before this session). Written to runs/s9/rows_<set>.npz.

    python docs/experiments_s9/rows.py shared|own|fresh
"""
import sys
from multiprocessing import Pool

sys.path.insert(0, "scripts")
import cv2  # noqa: E402
import numpy as np  # noqa: E402

import calibrate_attention as ca  # noqa: E402
from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, chroma, salient_regions, scene_maps  # noqa: E402
from impurity_attention.core.saliency import opponent_colour  # noqa: E402
from impurity_attention.core.verifier import FEATURES as SHIPPED, region_features  # noqa: E402

TOP = 3
P = AttentionParams()
EXTRA = ["log_score", "log_peak", "log_area", "rank", "score_over_best", "best_over_next", "log_regions",
         "area_share", "height_rel", "solidity", "rel_I", "light_diff", "chroma_dist", "bright_share",
         "dark_share", "log_object_share"]
FEATURES = list(SHIPPED) + EXTRA


def features(color, height):
    objects = height > P.density.occupied_height
    saliency, conspicuity = scene_maps(color, objects, P)
    regions = salient_regions(saliency, objects, P)
    rows = []
    ch = chroma(color)
    log_i = np.log(np.maximum(opponent_colour(color)[..., 0], 0.05))
    median_height = float(np.median(height[objects])) if objects.any() else 0.0
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
    for k, region in enumerate(regions[:TOP]):
        mask = region.mask
        shipped = region_features(color, height, objects, conspicuity, mask)
        if shipped is None:
            continue
        product = objects & ~(cv2.dilate(mask.astype(np.uint8), kernel) > 0)
        if not product.any():
            product = objects & ~mask
        level = max(float(conspicuity["I"][product].mean()), 1e-4)
        rel_i = float(np.log(max(conspicuity["I"][mask].mean() / level, 1e-3)))
        pc = ch[product]
        med = np.median(pc, axis=0)
        mad = np.median(np.linalg.norm(pc - med, axis=1)) + 1e-3
        chroma_dist = float(np.log1p(np.linalg.norm(np.median(ch[mask], axis=0) - med) / mad))
        pl = log_i[product]
        light_diff = float((np.median(log_i[mask]) - np.median(pl)) / (np.std(pl) + 1e-3))
        bright = float(np.mean(log_i[mask] > np.quantile(pl, 0.99)))
        dark = float(np.mean(log_i[mask] < np.quantile(pl, 0.01)))
        contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        solidity = region.area / max(cv2.contourArea(cv2.convexHull(np.vstack(contours))), 1.0)
        following = regions[1].score if len(regions) > 1 else regions[0].score / 2
        rows.append((k, mask, [*shipped, np.log(region.score), np.log(region.peak), np.log(region.area), k,
                               region.score / regions[0].score, np.log(regions[0].score / max(following, 1e-6)),
                               np.log(len(regions)), region.area / objects.sum(),
                               float(height[mask].mean()) - median_height, solidity, rel_i, light_diff,
                               chroma_dist, bright, dark, np.log(objects.mean())]))
    return rows


def one(args):
    i, record = args
    category = record.category()
    if category not in ("visible", "no_impurity", "invisible"):
        return []
    out = []
    for k, mask, row in features(record.color, record.height):
        on = bool(np.any(mask & record.visible_target_cells)) if category == "visible" else False
        out.append((i, record.palette or "blocks", category, k, on, row))
    if not out:
        out.append((i, record.palette or "blocks", category, -1, False, [0.0] * len(FEATURES)))
    return out


if __name__ == "__main__":
    which = sys.argv[1]
    if which == "shared":
        records, _ = ca.rule_sweep_records()
    elif which == "own":
        records = ca.collect_palettes("tuning", own_layouts=True)
    else:
        records = evaluation.load_records(ca.CACHE / "palettes_tuning_fresh.npz")
    with Pool(2) as pool:
        result = pool.map(one, list(enumerate(records)), chunksize=8)
    flat = [x for r in result for x in r]
    np.savez_compressed(f"runs/s9/rows_{which}.npz", scene=np.array([x[0] for x in flat]),
                        palette=np.array([x[1] for x in flat]), cat=np.array([x[2] for x in flat]),
                        rank=np.array([x[3] for x in flat]), on=np.array([x[4] for x in flat]),
                        X=np.array([x[5] for x in flat], float), features=np.array(FEATURES))
    print(which, len(records), "scenes,", len(flat), "rows")
