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

Slopes: the heightmap smoothed (Gaussian, sigma 1 px), Sobel. With fewer than 50 product cells the features
are 0. The features now live in impurity_attention.core.verifier (oriented_features, verifier.FEATURES), and
this script reads them from there; the screen and the second question ran at commit 0d10939 with this
script's own copy, which gives the same values (largest difference 2e-8 on 54 regions).

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

import numpy as np

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import verifier  # noqa: E402
from impurity_attention.core.attention import AttentionParams  # noqa: E402

TWELVE = tuple(name for name in verifier.FEATURES if name not in verifier.ORIENTED_FEATURES)
CAPS = (0.01, 0.02)


def fitting_rows(params):
    cache = ca.CACHE / "s20_verifier_rows.npz"  # verifier.FEATURES' columns
    if cache.exists():
        data = np.load(cache)
        return tuple(data[k] for k in ("features", "on", "scene", "group", "visible"))
    records, _ = ca.rule_sweep_records()
    records = records + ca.collect_palettes("tuning", own_layouts=True)
    result = ca.verifier_rows(records, params)
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


SETS = {"shipped 12": [verifier.FEATURES.index(name) for name in TWELVE],
        "12 + oriented 3": list(range(len(verifier.FEATURES)))}


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
    t_features, t_on, t_scene, _, t_visible = ca.verifier_rows(records, params)
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
