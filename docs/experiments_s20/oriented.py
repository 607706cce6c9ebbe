"""Twentieth session, tuning data only: does comparing a region with product cells *of the same surface
orientation* tell impurities from the product's own shading better than the shipped features do?

Two failures of the shipped verifier share one mechanism: the product's appearance depends on which way a
face points. At exposure x2 the default palette's lit faces clip cyan while faces in shade stay blue, and a
shaded face stands out (issue 17's x2 item); an impurity that is a lighter shade of the product's hue looks
like a lit face. Under one directional light, a surface's shading is a function of its normal, and the normal
can be read from the heightmap. So, per scene, the product's colour is modelled as a function of the local
slope (least squares of log I, RG / I and BY / I on 1, gx, gy, gx^2, gy^2, gx gy over the product cells, P as
the verifier defines it), and a region is judged by its residual from that model:

- oriented_contrast: log(1 + d), d the Mahalanobis distance of the region's mean residual from 0 under the
  product cells' residual covariance (+ 1e-4 I), capped at 100;
- oriented_lightness: median log-I residual over the region / standard deviation of the product's;
- oriented_off_share: the share of the region's cells whose own residual lies beyond 3 (Mahalanobis).

Slopes: the heightmap smoothed (Gaussian, sigma 1 px), Sobel / (8 x 2 mm). With fewer than 50 product cells
the features are 0.

    python docs/experiments_s20/oriented.py cv          # palette-grouped CV, 12 vs 12 + 3 features
    python docs/experiments_s20/oriented.py fresh 500 60 # fitted on all tuning rows, judged on fresh palettes
    python docs/experiments_s20/oriented.py exposure     # the default palette at x0.5 / x1 / x2, seeds 30000+
    python docs/experiments_s20/oriented.py exposure --seed-base 40000 --count-scale 2   # the second question

Rows: rule-sweep's tuning scenes (shared layouts, with the default palette also at x0.5 and x2) and the
tuning palettes' own-layout scenes, as `verifier-fit --own-layouts` (no picking-loop views: they are not
regenerated here). Scene decisions as verifier-fit's: the most probable of the three best regions, TARGET
from the threshold that lets 1 % (or 2 %) of the fitting scenes without a visible impurity through.
"""
import argparse
import sys

import cv2
import numpy as np

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import verifier  # noqa: E402
from impurity_attention.core.attention import AttentionParams, scene_maps  # noqa: E402
from impurity_attention.core.saliency import opponent_chromaticity  # noqa: E402
from impurity_common.cell import HEIGHTMAP_RESOLUTION  # noqa: E402

NEW = ("oriented_contrast", "oriented_lightness", "oriented_off_share")
MIN_PRODUCT = 50
CAPS = (0.01, 0.02)


def slopes(height: np.ndarray) -> tuple:
    smooth = cv2.GaussianBlur(height.astype(np.float32), (0, 0), 1.0)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3) / (8 * HEIGHTMAP_RESOLUTION)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3) / (8 * HEIGHTMAP_RESOLUTION)
    return gx, gy


def oriented_features(planes: np.ndarray, gx: np.ndarray, gy: np.ndarray, region: np.ndarray,
                      product: np.ndarray) -> np.ndarray:
    """(3,) NEW of `region` against `product` (module docstring); planes (H, W, 3): log I, RG / I, BY / I."""
    if product.sum() < MIN_PRODUCT:
        return np.zeros(len(NEW))

    def design(cells):
        x, y = gx[cells], gy[cells]
        return np.stack([np.ones_like(x), x, y, x * x, y * y, x * y], axis=1).astype(np.float64)

    yp = planes[product].astype(np.float64)
    beta, *_ = np.linalg.lstsq(design(product), yp, rcond=None)
    rp = yp - design(product) @ beta
    rm = planes[region].astype(np.float64) - design(region) @ beta
    inverse = np.linalg.inv(np.cov(rp, rowvar=False) + 1e-4 * np.eye(3))
    mean = rm.mean(axis=0)
    d = float(np.sqrt(max(mean @ inverse @ mean, 0.0)))
    per_cell = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", rm, inverse, rm), 0.0))
    lightness = float(np.median(rm[:, 0]) / (np.std(rp[:, 0]) + 1e-3))
    return np.array([np.log1p(min(d, 100.0)), lightness, float(np.mean(per_cell > 3.0))])


def rows(records, params: AttentionParams) -> tuple:
    """verifier_rows' rows with NEW appended: (features (N, 12 + 3), on, scene, group, visible)."""
    from impurity_attention.core.attention import salient_regions
    out, on, scene, group, visible = [], [], [], [], []
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * verifier.PRODUCT_MARGIN + 1,) * 2)
    for record in records:
        category = record.category()
        if category not in ca.evaluation.CATEGORIES:
            continue
        index = len(visible)
        visible.append(category == "visible")
        objects = record.height > params.density.occupied_height
        saliency, conspicuity = scene_maps(record.color, objects, params)
        regions = salient_regions(saliency, objects, params)
        chroma = opponent_chromaticity(record.color)
        planes = np.concatenate([np.log(np.maximum(chroma[..., :1], 0.02)), chroma[..., 1:]], axis=-1)
        gx, gy = slopes(record.height)
        for region, row in verifier.candidate_features(record.color, record.height, objects, conspicuity,
                                                       regions):
            if row is None:
                continue
            product = objects & ~(cv2.dilate(region.mask.astype(np.uint8), kernel) > 0)
            if not product.any():
                product = objects & ~region.mask
            out.append(np.concatenate([row, oriented_features(planes, gx, gy, region.mask, product)]))
            on.append(category == "visible" and bool(np.any(region.mask & record.visible_target_cells)))
            scene.append(index)
            group.append(record.palette or "blocks")
    return np.array(out), np.array(on, bool), np.array(scene), np.array(group), np.array(visible, bool)


def fitting_rows(params):
    cache = ca.CACHE / "s20_oriented_rows.npz"
    if cache.exists():
        data = np.load(cache)
        return tuple(data[k] for k in ("features", "on", "scene", "group", "visible"))
    records, _ = ca.rule_sweep_records()
    records = records + ca.collect_palettes("tuning", own_layouts=True)
    result = rows(records, params)
    names = ("features", "on", "scene", "group", "visible")
    np.savez_compressed(cache, **dict(zip(names, result, strict=True)))
    return result


def fit(features, labels):
    from sklearn.linear_model import LogisticRegression
    from sklearn.preprocessing import StandardScaler
    scaler = StandardScaler().fit(features)
    return scaler, LogisticRegression(C=1.0, max_iter=5000).fit(scaler.transform(features), labels)


def predict(fitted, features):
    scaler, model = fitted
    return model.predict_proba(scaler.transform(features))[:, 1]


SETS = {"shipped 12": slice(0, 12), "12 + oriented 3": slice(0, 15)}


def cross_validate(params) -> None:
    from sklearn.model_selection import GroupKFold
    features, on, scene, group, visible = fitting_rows(params)
    count = len(visible)
    print(f"{count} scenes ({int(visible.sum())} visible), {len(features)} regions, "
          f"{len(set(group))} palettes")
    for name, columns in SETS.items():
        x = features[:, columns]
        nested = np.zeros((len(CAPS), 4))
        for train, test in GroupKFold(n_splits=ca.VERIFIER_FOLDS).split(x, on, group):
            fitted = fit(x[train], on[train])
            own_best, _ = ca.scene_decisions(predict(fitted, x[train]), on[train], scene[train], count)
            seen = np.zeros(count, bool)
            seen[scene[train]] = True
            best, hit = ca.scene_decisions(predict(fitted, x[test]), on[test], scene[test], count)
            unseen = np.zeros(count, bool)
            unseen[scene[test]] = True
            for k, cap in enumerate(CAPS):
                least = ca.threshold_at(own_best[seen], visible[seen], cap)
                decided = (best >= least) & unseen
                nested[k] += (np.sum(decided & hit & visible), np.sum(unseen & visible),
                              np.sum(decided & ~visible), np.sum(unseen & ~visible))
        print(f"{name:18s} " + "  ".join(
            f"cap {cap:.0%}: found {n[0] / n[1]:.1%} ({int(n[0])}/{int(n[1])}), "
            f"false TARGET {n[2] / n[3]:.1%}" for cap, n in zip(CAPS, nested, strict=True)))


def judged(records, params, label: str) -> None:
    """Both feature sets fitted on all the fitting rows (threshold at each cap), judged on `records`."""
    features, on, scene, group, visible = fitting_rows(params)
    count = len(visible)
    t_features, t_on, t_scene, _, t_visible = rows(records, params)
    for name, columns in SETS.items():
        fitted = fit(features[:, columns], on)
        best_fit, _ = ca.scene_decisions(predict(fitted, features[:, columns]), on, scene, count)
        best, hit = ca.scene_decisions(predict(fitted, t_features[:, columns]), t_on, t_scene, len(t_visible))
        parts = []
        for cap in CAPS:
            least = ca.threshold_at(best_fit, visible, cap)
            decided = best >= least
            parts.append(f"cap {cap:.0%} (t {least:.2f}): found {np.sum(decided & hit & t_visible)}/"
                         f"{t_visible.sum()}, false TARGET {np.sum(decided & ~t_visible)}/"
                         f"{np.sum(~t_visible)}")
        print(f"{label} {name:18s} " + "  ".join(parts))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("action", choices=("cv", "fresh", "exposure"))
    parser.add_argument("--seed-base", type=int, default=ca.EXPOSURE_CHECK_SEED_BASE,
                        help="exposure: the exposure set's first seed (30000: the screen's)")
    parser.add_argument("--count-scale", type=float, default=1.0, help="exposure: scenes per row, times")
    parser.add_argument("first", nargs="?", type=int, default=500)
    parser.add_argument("count", nargs="?", type=int, default=60)
    args = parser.parse_args()
    params = AttentionParams()
    if args.action == "cv":
        cross_validate(params)
    elif args.action == "fresh":
        sys.path.insert(0, "docs/experiments_s12")
        from fresh_tuning_palettes import fresh_records
        judged(fresh_records(args.first, args.count), params, f"random-{args.first}+{args.count}:")
    else:
        base = ca.collect_exposure_scenes(args.seed_base, args.count_scale)
        for exposure in ca.EXPOSURES:
            judged([r.exposed(exposure) for r in base], params, f"default x{exposure:g}:")


if __name__ == "__main__":
    main()
