"""Twenty-fourth session, tuning data only: does a model with more capacity than the shipped logistic
regression separate impurity regions better on palettes it never saw?

`collect` computes the verifier's training rows once (calibrate_attention.verifier_rows on the shipped
recipe's scenes: rule-sweep's tuning first views, the tuning palettes' own layouts, the twenty-first
session's picking-loop views) and saves them; `compare` refits each candidate model in palette-grouped
folds (GroupKFold, VERIFIER_FOLDS: every scene scored by a model that never saw its palette) and prints, at
the threshold each model's out-of-fold first views put at 1 % false TARGET on scenes without a visible
impurity (calibrate_attention.VERIFIER_FALSE_TARGET), found / false TARGET on first views and on loop views.

    python docs/experiments_s24/verifier_models.py collect runs/s24/rows.npz \
        runs/s21/views_inv.npz runs/s21/views_chal.npz runs/s21/views_rand.npz
    python docs/experiments_s24/verifier_models.py compare runs/s24/rows.npz
    python docs/experiments_s24/verifier_models.py exposure-rows runs/s24/exposure_rows.npz 55100 2
    python docs/experiments_s24/verifier_models.py screen runs/s24/rows.npz runs/s24/exposure_rows.npz

The trees the cell could read (RegionVerifier.trees, `verifier-fit --model trees`) and this script's
`even` command (the even-palette trees for the last look) existed at commit 7f29852 only; they were taken
back when the trees failed their exposure check (docs/experiments.md, twenty-fourth section).
"""
import sys

import numpy as np

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams  # noqa: E402
from impurity_attention.core.verifier import FEATURES, default_verifier  # noqa: E402


def collect(out: str, loop_paths: list) -> None:
    params = AttentionParams()
    records, _ = ca.rule_sweep_records()
    records = records + ca.collect_palettes("tuning", own_layouts=True)
    loop = [r for path in loop_paths for r in evaluation.load_records(path)]
    kinds = [r.category() for r in records + loop if r.category() in evaluation.CATEGORIES]
    first = sum(r.category() in evaluation.CATEGORIES for r in records)
    features, on, scene, group, visible = ca.verifier_rows(records + loop, params)
    np.savez(out, features=features, on=on, scene=scene, group=group, visible=visible,
             kind=np.array(kinds), first=first)
    print(f"{out}: {len(visible)} scenes ({first} first views), {len(features)} regions")


TREES = dict(n_estimators=200, learning_rate=0.1, max_depth=3, subsample=0.8, random_state=0)  # the candidate


def load_rows(path: str) -> tuple:
    """(the saved rows, fill): fill(rows) keeps the shipped model's columns of (N, len(FEATURES)) rows and
    reads an unknown value (NaN) as that column's mean over the saved rows, as the shipped model does."""
    data = np.load(path)
    columns = [FEATURES.index(name) for name in default_verifier().features]
    mean = np.nanmean(data["features"][:, columns], axis=0)

    def fill(rows):
        rows = rows[:, columns]
        return np.where(np.isnan(rows), mean, rows)

    return data, fill


def out_of_fold(make, filled, data) -> tuple:
    """(best, hit, least): each scene's likeliest region probability from a model (make()) that never saw its
    palette (GroupKFold, VERIFIER_FOLDS), whether that region is on the impurity, and the threshold those
    probabilities put at VERIFIER_FALSE_TARGET of the first views without a visible impurity."""
    from sklearn.model_selection import GroupKFold
    on, scene, group, visible, first = (data[k] for k in ("on", "scene", "group", "visible", "first"))
    unseen = np.zeros(len(filled))
    for train, test in GroupKFold(n_splits=ca.VERIFIER_FOLDS).split(filled, on, group):
        unseen[test] = make().fit(filled[train], on[train]).predict_proba(filled[test])[:, 1]
    best, hit = ca.scene_decisions(unseen, on, scene, len(visible))
    first = int(first)
    return best, hit, ca.threshold_at(best[:first], visible[:first], ca.VERIFIER_FALSE_TARGET)


def models():
    from sklearn.ensemble import GradientBoostingClassifier, HistGradientBoostingClassifier
    from sklearn.linear_model import LogisticRegression
    from sklearn.neural_network import MLPClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import PolynomialFeatures, StandardScaler

    return {
        "logistic (shipped recipe)": lambda: make_pipeline(
            StandardScaler(), LogisticRegression(C=1.0, max_iter=5000)),
        "logistic, pairwise products": lambda: make_pipeline(
            StandardScaler(), PolynomialFeatures(2), StandardScaler(),
            LogisticRegression(C=0.1, max_iter=5000)),
        "MLP 16, alpha 1e-2": lambda: make_pipeline(StandardScaler(), MLPClassifier(
            (16,), alpha=1e-2, max_iter=2000, random_state=0)),
        "MLP 32-16, alpha 1e-2": lambda: make_pipeline(StandardScaler(), MLPClassifier(
            (32, 16), alpha=1e-2, max_iter=2000, random_state=0)),
        "gradient boosting": lambda: HistGradientBoostingClassifier(
            max_iter=300, learning_rate=0.05, max_leaf_nodes=15, l2_regularization=1.0, random_state=0),
        "gradient boosting, 150 x 7 leaves": lambda: HistGradientBoostingClassifier(
            max_iter=150, learning_rate=0.1, max_leaf_nodes=7, l2_regularization=1.0, random_state=0),
        "gradient boosting, 600 x 31 leaves": lambda: HistGradientBoostingClassifier(
            max_iter=600, learning_rate=0.025, max_leaf_nodes=31, l2_regularization=1.0, random_state=0),
        "GradientBoosting 200 x depth 3": lambda: GradientBoostingClassifier(**TREES),
        "GradientBoosting 300 x depth 4": lambda: GradientBoostingClassifier(
            n_estimators=300, learning_rate=0.05, max_depth=4, subsample=0.8, random_state=0),
    }


def compare(path: str, only: tuple = ()) -> None:
    data, fill = load_rows(path)
    filled = fill(data["features"])
    group, visible, kind = data["group"], data["visible"], data["kind"]
    first, count = int(data["first"]), len(visible)
    print(f"{count} scenes ({first} first views, {count - first} loop views), {len(filled)} regions, "
          f"{len(set(group))} palettes")
    print("model                         | first views: found   clean  invisible | loop: found  none in view")
    for name, make in models().items():
        if only and not any(o in name for o in only):
            continue
        best, hit, least = out_of_fold(make, filled, data)
        cells = []
        for part in (slice(0, first), slice(first, None)):
            taken, shown, what = best[part] >= least, visible[part], kind[part]
            cells.append((100 * np.mean(taken[shown] & hit[part][shown]),
                          100 * np.mean(taken[what == "no_impurity"]) if np.any(what == "no_impurity") else 0,
                          100 * np.mean(taken[what == "invisible"]) if np.any(what == "invisible") else 0,
                          100 * np.mean(taken[~shown])))
        (f, c, i, _), (lf, _, _, ln) = cells
        print(f"{name:29s} | {f:5.1f} %  {c:5.1f} %  {i:5.1f} %      | {lf:5.1f} %  {ln:5.1f} %   "
              f"(t {least:.3f})")
        sys.stdout.flush()


def exposure_rows(out: str, seed_base: int = 55100, count_scale: float = 2.0) -> None:
    """The verifier's rows of the default palette's exposure scenes (exposure_wide.py's) at each exposure."""
    params = AttentionParams()
    records = ca.collect_exposure_scenes(seed_base, count_scale)
    saved = {}
    for exposure in ca.EXPOSURES:
        features, on, scene, group, visible = ca.verifier_rows([r.exposed(exposure) for r in records], params)
        for name, values in zip(("features", "on", "scene", "visible"), (features, on, scene, visible),
                                strict=True):
            saved[f"{name}_{exposure:g}"] = values
    np.savez(out, **saved)


def screen(path: str, exposure_path: str, names: tuple) -> None:
    """Each candidate fitted on all the tuning rows, its threshold out of fold (1 % of the first views without
    a visible impurity), then read on the exposure rows: false TARGET / found per exposure (the main
    threshold only: no last look)."""
    (data, fill), exposed = load_rows(path), np.load(exposure_path)
    filled, on, visible, first = fill(data["features"]), data["on"], data["visible"], int(data["first"])
    for name, make in candidates().items():
        if names and not any(n in name for n in names):
            continue
        best, hit, least = out_of_fold(make, filled, data)
        found = [100 * np.mean((best[part] >= least)[visible[part]] & hit[part][visible[part]])
                 for part in (slice(0, first), slice(first, None))]
        loop_false = 100 * np.mean((best[first:] >= least)[~visible[first:]])
        model = make().fit(filled, on)
        cells = []
        for exposure in ca.EXPOSURES:
            e = f"{exposure:g}"
            shown = exposed[f"visible_{e}"]
            p = model.predict_proba(fill(exposed[f"features_{e}"]))[:, 1]
            eb, eh = ca.scene_decisions(p, exposed[f"on_{e}"], exposed[f"scene_{e}"], len(shown))
            cells.append(f"x{e} {int(np.sum((eb >= least) & ~shown))}/{int(np.sum(~shown))} "
                         f"found {int(np.sum((eb >= least) & eh & shown))}/{int(shown.sum())}")
        print(f"{name:34s} t {least:.3f} | OOF first {found[0]:5.1f} loop {found[1]:5.1f} "
              f"(false {loop_false:.1f}) | {'; '.join(cells)}")
        sys.stdout.flush()


def candidates():
    from sklearn.ensemble import GradientBoostingClassifier
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import PolynomialFeatures, StandardScaler

    def logistic():
        return make_pipeline(StandardScaler(), LogisticRegression(C=1.0, max_iter=5000))

    return {
        "logistic (shipped recipe)": logistic,
        "logistic, pairwise products": lambda: make_pipeline(
            StandardScaler(), PolynomialFeatures(2), StandardScaler(),
            LogisticRegression(C=0.1, max_iter=5000)),
        "trees 200 x depth 3": lambda: GradientBoostingClassifier(**TREES),
        "logistic + trees 50 x depth 2": lambda: GradientBoostingClassifier(
            init=logistic(), n_estimators=50, max_depth=2, learning_rate=0.1, subsample=0.8, random_state=0),
        "logistic + trees 100 x depth 2": lambda: GradientBoostingClassifier(
            init=logistic(), n_estimators=100, max_depth=2, learning_rate=0.1, subsample=0.8, random_state=0),
        "logistic + trees 100 x depth 3": lambda: GradientBoostingClassifier(
            init=logistic(), n_estimators=100, max_depth=3, learning_rate=0.1, subsample=0.8, random_state=0),
        "trees 200 x depth 2": lambda: GradientBoostingClassifier(
            n_estimators=200, max_depth=2, learning_rate=0.1, subsample=0.8, random_state=0),
        "trees 400 x depth 3, min leaf 50": lambda: GradientBoostingClassifier(
            n_estimators=400, max_depth=3, learning_rate=0.05, subsample=0.8, min_samples_leaf=50,
            random_state=0),
    }


if __name__ == "__main__":
    if sys.argv[1] == "collect":
        collect(sys.argv[2], sys.argv[3:])
    elif sys.argv[1] == "exposure-rows":
        exposure_rows(sys.argv[2], *(int(a) for a in sys.argv[3:4]), *(float(a) for a in sys.argv[4:5]))
    elif sys.argv[1] == "screen":
        screen(sys.argv[2], sys.argv[3], tuple(sys.argv[4:]))
    else:
        compare(sys.argv[2], tuple(sys.argv[3:]))
