"""Thirteenth session, tuning palettes only: is the logistic verifier's form what holds it back? Most
misses on fresh tuning palettes are impurities that are one of the verifier's candidates but score under its
threshold (docs/experiments_s13/candidates.py). Same features, same rows, same palette-grouped
cross-validation and 1 % false-TARGET threshold as `calibrate_attention.py verifier-fit --own-layouts`;
models compared: logistic (the shipped form), a small MLP, gradient-boosted trees. Then each, fitted on all
the rows, is scored on fresh tuning palette sets by the same scene decision (the likeliest candidate at or
over the threshold).

    python docs/experiments_s13/nonlinear.py cv [extra]      # extra: the 200 extra palettes join the rows
    python docs/experiments_s13/nonlinear.py fresh 500 600 [--extra] [--caps=0.01,0.02]

Rows are cached in runs/s13/rows_<name>.npz.
"""
import pathlib
import sys

import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402

CACHE = pathlib.Path("runs/s13")
CAP = ca.VERIFIER_FALSE_TARGET


def rows(name: str, records_of) -> tuple:
    path = CACHE / f"rows_{name}.npz"
    if path.exists():
        data = np.load(path)
        return tuple(data[k] for k in ("features", "on", "scene", "group", "visible"))
    result = ca.verifier_rows(records_of(), AttentionParams())
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(path, **dict(zip(("features", "on", "scene", "group", "visible"), result, strict=True)))
    return result


def shipped_records() -> list:
    """The shipped fit's scenes (verifier-fit --own-layouts): rule-sweep's and the tuning own layouts."""
    return ca.rule_sweep_records()[0] + ca.collect_palettes("tuning", own_layouts=True)


def shipped_rows_of(rows_of) -> tuple:
    return rows_of("shipped", shipped_records)


def shipped_rows():
    return shipped_rows_of(rows)


def extra_rows():
    import more_palettes
    return rows("extra192", lambda: more_palettes.extra_records(200))


def fresh_rows(first: int):
    import fresh_tuning_palettes
    return rows(f"fresh{first}", lambda: fresh_tuning_palettes.fresh_records(first, 60))


def join(*parts) -> tuple:
    features, on, scene, group, visible = [], [], [], [], []
    offset = 0
    for f, o, s, g, v in parts:
        features.append(f), on.append(o), scene.append(s + offset), group.append(g), visible.append(v)
        offset += len(v)
    return tuple(np.concatenate(x) for x in (features, on, scene, group, visible))


def models() -> dict:
    from sklearn.ensemble import HistGradientBoostingClassifier
    from sklearn.linear_model import LogisticRegression
    from sklearn.neural_network import MLPClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler
    return {
        "logistic": lambda: make_pipeline(StandardScaler(), LogisticRegression(C=1.0, max_iter=5000)),
        "mlp16": lambda: make_pipeline(StandardScaler(), MLPClassifier((16,), alpha=1e-2, max_iter=2000,
                                                                       random_state=0)),
        "mlp32x2": lambda: make_pipeline(StandardScaler(), MLPClassifier((32, 32), alpha=1e-2, max_iter=2000,
                                                                         random_state=0)),
        "trees": lambda: HistGradientBoostingClassifier(max_depth=4, learning_rate=0.05, max_iter=300,
                                                        random_state=0),
    }


def scene_rate(probability, on, scene, visible, least) -> tuple:
    best, hit = ca.scene_decisions(probability, on, scene, len(visible))
    decided = best >= least
    return float(np.mean(decided[visible] & hit[visible])), float(np.mean(decided[~visible]))


def cv(data) -> None:
    from sklearn.model_selection import GroupKFold
    features, on, scene, group, visible = data
    count = len(visible)
    print(f"{count} scenes, {len(features)} regions, {len(set(group))} palettes")
    for name, make in models().items():
        found = clean = false = seen_visible = 0
        for train, test in GroupKFold(n_splits=ca.VERIFIER_FOLDS).split(features, on, group):
            model = make().fit(features[train], on[train])
            own_best, _ = ca.scene_decisions(model.predict_proba(features[train])[:, 1], on[train],
                                             scene[train], count)
            seen = np.zeros(count, bool)
            seen[scene[train]] = True
            least = ca.threshold_at(own_best[seen], visible[seen], CAP)
            best, hit = ca.scene_decisions(model.predict_proba(features[test])[:, 1], on[test], scene[test],
                                           count)
            unseen = np.zeros(count, bool)
            unseen[scene[test]] = True
            decided = (best >= least) & unseen
            found += np.sum(decided & hit & visible)
            seen_visible += np.sum(unseen & visible)
            false += np.sum(decided & ~visible)
            clean += np.sum(unseen & ~visible)
        print(f"  {name:10s} nested CV: found {100 * found / seen_visible:5.1f} %, false TARGET "
              f"{100 * false / clean:.1f} %")


def fresh(data, sets: dict, caps=(CAP,)) -> None:
    """Each model fitted on all of `data`, its threshold the least that lets through `cap` of the rows'
    scenes without a visible impurity; scored on the fresh sets ({first palette: rows as `data`}; false
    TARGET over every scene without a visible impurity: no_impurity and invisible)."""
    features, on, scene, group, visible = data
    for name, make in models().items():
        model = make().fit(features, on)
        best, _ = ca.scene_decisions(model.predict_proba(features)[:, 1], on, scene, len(visible))
        for cap in caps:
            least = ca.threshold_at(best, visible, cap)
            line = f"  {name:10s} cap {100 * cap:.0f} % threshold {least:.3f}:"
            for first, (f, o, s, _, v) in sets.items():
                found, false = scene_rate(model.predict_proba(f)[:, 1], o, s, v, least)
                line += f"  random-{first}+ found {100 * found:5.1f} % false TARGET {100 * false:.1f} %"
            print(line)


def main() -> None:
    command, rest = sys.argv[1], sys.argv[2:]
    extra = "extra" in rest or "--extra" in rest
    data = join(shipped_rows(), extra_rows()) if extra else shipped_rows()
    if command == "cv":
        cv(data)
    else:
        caps = [float(a[len("--caps="):].split(",")[i]) for a in rest if a.startswith("--caps=")
                for i in range(len(a[len("--caps="):].split(",")))] or [CAP]
        fresh(data, {int(a): fresh_rows(int(a)) for a in rest if a.isdigit()}, caps)


if __name__ == "__main__":
    main()
