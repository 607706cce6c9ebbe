"""Seventh session, tuning data only: attention judged on surfaces facing the camera, and the lightness
weight. Run from the repository root after `source scripts/env.sh`:

    PYTHONPATH=scripts:$PYTHONPATH python docs/experiments_s7/facing_and_lightness.py FACING LW [colour-only]

FACING: least cosine of a cell's surface tilt (heightmap normal, Gaussian sigma 1 px) for the cell to be
judged, 0 = every object cell; LW: AttentionParams.lightness_weight; colour-only: saliency on every object
cell, the colour test on facing cells only. Prints, per colour test (shading, saturation), the most
visible impurities found (best region on the impurity and a target) within 1 / 2 / 5 % false TARGET
over a grid of the four thresholds, on rule-sweep's scenes (tuning palettes, the default's tuning scenes,
the default at x0.5 and x2)."""
import dataclasses
import sys

import cv2
import numpy as np

import calibrate_attention as ca
from impurity_attention.core.attention import (AttentionParams, is_target, region_color_contrast,
                                               salient_regions, scene_saliency)

facing_min, lw = float(sys.argv[1]), float(sys.argv[2])
colour_only = len(sys.argv) > 3 and sys.argv[3] == "colour-only"
params = AttentionParams(lightness_weight=lw)
tests = [(0.0, 0.0), (0.1, 250.0)]


def facing_cells(height, objects):
    if facing_min <= 0:
        return objects
    smooth = cv2.GaussianBlur(height.astype(np.float32), (0, 0), 1.0)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3) / (8 * 0.002)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3) / (8 * 0.002)
    facing = objects & (1.0 / np.sqrt(1 + gx ** 2 + gy ** 2) >= facing_min)
    return facing if facing.sum() >= 0.25 * objects.sum() else objects


records, _ = ca.rule_sweep_records()
vis, clean = [], []
for r in records:
    category = r.category()
    if category not in ("visible", "no_impurity", "invisible"):
        continue
    objects = r.height > params.density.occupied_height
    judged = facing_cells(r.height, objects)
    seen = objects if colour_only else judged
    regions = salient_regions(scene_saliency(r.color, seen, params), seen, params)
    best = regions[0] if regions else None
    on = best is not None and bool(np.any(best.mask & r.visible_target_cells))
    colours = [region_color_contrast(r.color, judged, best, dataclasses.replace(
        params, color_shading=s, color_saturation=level)) if best is not None else 0.0 for s, level in tests]
    (vis if category == "visible" else clean).append((best.score if best else 0.0, on, *colours))
vis, clean = np.array(vis, float), np.array(clean, float)
on = vis[:, 1].astype(bool)
print(f"facing {facing_min} lw {lw}{' colour-only' if colour_only else ''}: best region on the impurity "
      f"{100 * on.mean():.1f} % of {len(vis)}; {len(clean)} scenes without a visible impurity")
for k, test in enumerate(tests):
    best = {0.01: (0, 0, None), 0.02: (0, 0, None), 0.05: (0, 0, None)}
    for s1 in np.round(np.arange(3.0, 8.01, 0.2), 2):
        for c1 in (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0):
            for c2 in np.round(np.arange(2.0, 8.01, 0.5), 2):
                for s2 in np.round(np.arange(2.0, s1 + 1e-9, 0.2), 2):
                    p = dataclasses.replace(params, min_relative_contrast=float(s1), min_color_contrast=c1,
                                            distinct_color_contrast=float(c2),
                                            min_relative_contrast_distinct=float(s2))
                    found = float(np.mean(on & is_target(vis[:, 0], vis[:, 2 + k], p)))
                    false = float(np.mean(is_target(clean[:, 0], clean[:, 2 + k], p)))
                    for cap in best:
                        if false <= cap + 1e-12 and found > best[cap][0]:
                            best[cap] = (found, false, (float(s1), c1, float(c2), float(s2)))
    print(f"  colour test (shading, saturation) {test}: " + "  ".join(
        f"<= {100 * cap:.0f} %: {100 * b[0]:.1f} ({100 * b[1]:.1f}) at {b[2]}" for cap, b in best.items()))
