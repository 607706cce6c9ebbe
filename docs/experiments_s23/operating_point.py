"""Twenty-third session, tuning data only: what an unseen palette gets from the verifier at each threshold.

The shipped recipe (calibrate_attention.verifier_fit: the tuning first views on shared and own layouts, the
twenty-first session's picking-loop views, logistic regression on standardised features) is refitted in
palette-grouped folds (GroupKFold, VERIFIER_FOLDS), so every scene is scored by a model that never saw its
palette, as a held-out palette is. For thresholds t, per part (first views; loop views), it prints:
visible impurities found (the likeliest region reaches t and lies on the impurity), TARGET on scenes
without a visible impurity (clean first views; loop views with none in view), and TARGET on invisible-
scenario first views. Also the same with the model fitted on everything (in-sample, what the shipped
threshold was set on).

    python docs/experiments_s23/operating_point.py runs/s21/views_inv.npz runs/s21/views_chal.npz \
        runs/s21/views_rand.npz > runs/s23/operating_point.txt
"""
import sys

import numpy as np

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams  # noqa: E402
from impurity_attention.core.verifier import default_verifier  # noqa: E402

THRESHOLDS = (0.5, 0.6, 0.65, 0.7, 0.75, 0.8, 0.8125, 0.85, 0.9)


def main() -> None:
    from sklearn.linear_model import LogisticRegression
    from sklearn.model_selection import GroupKFold
    from sklearn.preprocessing import StandardScaler

    params = AttentionParams()
    records, _ = ca.rule_sweep_records()
    records = records + ca.collect_palettes("tuning", own_layouts=True)
    loop = [r for path in sys.argv[1:] for r in evaluation.load_records(path)]
    categories = [r.category() for r in records + loop if r.category() in evaluation.CATEGORIES]
    first = sum(r.category() in evaluation.CATEGORIES for r in records)
    features, on, scene, group, visible = ca.verifier_rows(records + loop, params)
    count = len(visible)
    columns = list(default_verifier().features)
    from impurity_attention.core.verifier import FEATURES
    features = features[:, [FEATURES.index(name) for name in columns]]

    def fit_predict(train, test):
        scaler = StandardScaler().fit(features[train])
        model = LogisticRegression(C=1.0, max_iter=5000).fit(
            np.nan_to_num(scaler.transform(features[train]), nan=0.0), on[train])
        return model.predict_proba(np.nan_to_num(scaler.transform(features[test]), nan=0.0))[:, 1]

    out_of_fold = np.zeros(len(features))
    for train, test in GroupKFold(n_splits=ca.VERIFIER_FOLDS).split(features, on, group):
        out_of_fold[test] = fit_predict(train, test)
    everything = np.arange(len(features))
    in_sample = fit_predict(everything, everything)
    kind = np.array(categories)
    print(f"{count} scenes ({first} first views, {count - first} loop views), {len(set(group))} palettes")
    for name, probability in (("out of fold (palettes unseen)", out_of_fold), ("in sample", in_sample)):
        best, hit = ca.scene_decisions(probability, on, scene, count)
        print(f"== {name}")
        print("   t    | first views: found / visible  TARGET clean  TARGET invisible | loop views: found / visible"
              "  TARGET with none in view")
        parts = {"first": slice(0, first), "loop": slice(first, None)}
        for t in THRESHOLDS:
            cells = []
            for part in parts.values():
                taken, shown, what = best[part] >= t, visible[part], kind[part]
                found = np.sum(taken & hit[part] & shown)
                cells.append((found, int(shown.sum()), np.sum(taken & (what == "no_impurity")),
                              int(np.sum(what == "no_impurity")), np.sum(taken & (what == "invisible")),
                              int(np.sum(what == "invisible"))))
            (f, v, c, nc, i, ni), (lf, lv, lc, lnc, li, lni) = cells
            print(f"  {t:6.4f} | {100 * f / v:5.1f} % of {v}   {100 * c / max(nc, 1):4.1f} % of {nc}   "
                  f"{100 * i / max(ni, 1):4.1f} % of {ni} | {100 * lf / max(lv, 1):5.1f} % of {lv}   "
                  f"{100 * (lc + li) / max(lnc + lni, 1):4.1f} % of {lnc + lni}")


if __name__ == "__main__":
    main()
