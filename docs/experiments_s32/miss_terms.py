"""Thirty-second session, tuning data only, a diagnosis (nothing is chosen on it): on the 260 fresh random
tuning palettes of threshold_curve.py (cached renders), which of the verifier's features hold the missed
impurities down?

For every visible scene, the scored candidate region (verifier.candidate_features, as attend scores them)
that overlaps the impurity most: its probability and each feature's term coef * (clip(x) - mean) / scale in
the logit. Printed: how many missed scenes have the impurity among the scored regions and with what
probability, and per feature the mean term over the impurity regions of missed scenes against found ones
(the difference is what a better feature would have to make up). Also the palette's ΔE (impurity to nearest
product shade) and whether the impurity is lighter or darker than the product (CIE L*).

    python docs/experiments_s32/miss_terms.py
"""
import sys
from collections import defaultdict

import cv2
import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
sys.path.insert(0, "docs/experiments_s13")
import fresh_layouts  # noqa: E402
import more_palettes  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend, salient_regions, sanitize, scene_maps  # noqa: E402
from impurity_attention.core.verifier import FEATURES, candidate_features, default_verifier  # noqa: E402
from ur5_driver_sim.core.appearance import delta_e, palette_named  # noqa: E402


def lightness(rgb) -> float:
    """CIE L* of an RGB colour in [0, 1], by OpenCV's Lab (D65), as appearance.delta_e reads colours."""
    return float(cv2.cvtColor(np.array([[rgb]], dtype=np.float32), cv2.COLOR_RGB2Lab)[0, 0, 0])


def palette_facts(name: str) -> tuple:
    """(ΔE of the closest impurity colour to its nearest product shade, L* impurity - L* that shade)."""
    palette = palette_named(name)
    best = min((delta_e(i, q), lightness(i) - lightness(q)) for i in palette.impurity_colors
                for q in palette.product_shades)
    return best


def main() -> None:
    params = AttentionParams()
    model = default_verifier()
    records = more_palettes.extra_records(200) + fresh_layouts.own_layout_records(700, 60)
    terms = {True: [], False: []}
    probability = {True: [], False: []}
    unscored = 0
    by_palette = defaultdict(lambda: [0, 0])
    for record in records:
        if record.category() != "visible":
            continue
        found = evaluation.judge(record, attend(record.color, record.height, params)).success
        by_palette[record.palette][0] += found
        by_palette[record.palette][1] += 1
        color, height = sanitize(record.color, record.height)
        objects = height > params.density.occupied_height
        saliency, conspicuity = scene_maps(color, objects, params)
        regions = salient_regions(saliency, objects, params)
        target = record.visible_target_cells
        best = None
        for region, features in candidate_features(color, height, objects, conspicuity, regions):
            if features is None:
                continue
            overlap = int(np.count_nonzero(region.mask & target))
            if overlap and (best is None or overlap > best[0]):
                best = (overlap, features)
        if best is None:
            unscored += not found
            continue
        features = best[1]
        clipped = np.clip(features, model.low, model.high)
        scaled = (clipped - np.asarray(model.mean)) / np.asarray(model.scale)
        terms[found].append(np.asarray(model.coef) * scaled)
        probability[found].append(float(model.probability(features)[0]))
    missed = sum(v - f for f, v in by_palette.values())
    print(f"{sum(v for _, v in by_palette.values())} visible scenes, {missed} missed; of the misses, "
          f"{unscored} have no scored region on the impurity, {len(probability[False])} have one")
    p = np.array(probability[False])
    bands = ", ".join(f"< {t}: {int((p < t).sum())}" for t in (0.1, 0.3, 0.5, 0.6, 0.7, 0.813))
    print(f"impurity region's probability in missed scenes: {bands} (threshold {model.threshold:.3f})")
    print(f"found scenes' impurity regions: median probability {np.median(probability[True]):.2f}")
    # nanmean: a feature the model cannot read on a region (an oriented one without enough unclipped product
    # cells, verifier.oriented_features) is NaN there; the count of such regions is printed beside it
    missed_terms, found_terms = np.nanmean(terms[False], axis=0), np.nanmean(terms[True], axis=0)
    unread = np.isnan(terms[False]).sum(axis=0), np.isnan(terms[True]).sum(axis=0)
    order = np.argsort(missed_terms - found_terms)
    print("feature                         term: missed   found   missed - found   NaN in missed / found")
    for k in order:
        difference = missed_terms[k] - found_terms[k]
        print(f"  {FEATURES[k]:30s} {missed_terms[k]:+8.2f} {found_terms[k]:+8.2f} {difference:+8.2f}"
              f"   {unread[0][k]} / {unread[1][k]}")
    print("palettes with a miss: found/visible, ΔE, L* impurity - product")
    for name, (found, visible) in sorted(by_palette.items(), key=lambda kv: kv[1][0] / kv[1][1]):
        if found < visible:
            d, dl = palette_facts(name)
            print(f"  {name:14s} {found:2d}/{visible:2d}  ΔE {d:5.1f}  ΔL* {dl:+6.1f}")


if __name__ == "__main__":
    main()
