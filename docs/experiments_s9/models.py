"""Ninth session, tuning data only: region-verifier models fitted on the shared and own-layout tuning scenes
(rows.py) and measured on the fresh tuning palettes (random-96 ... 191, never used to choose before). The
threshold is chosen on the training scenes' own predictions at a false-TARGET cap and applied unchanged to the
fresh scenes (as a shipped threshold is). Also a palette-grouped 5-fold cross-validation on the training scenes.

    python docs/experiments_s9/models.py   (from the repository root) [feature names ...]   (default: several sets)
"""
import pathlib
import sys

import numpy as np
from sklearn.ensemble import HistGradientBoostingClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.model_selection import GroupKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

ROOT = pathlib.Path(__file__).resolve().parents[2]
ROWS = ROOT / "runs" / "s9"
sys.path.insert(0, str(ROOT / "src" / "impurity_attention"))
from impurity_attention.core.verifier_model import MODEL  # noqa: E402


def load(*names):
    parts = [np.load(ROWS / f"rows_{n}.npz") for n in names]
    offset, data = 0, {k: [] for k in ("scene", "palette", "cat", "rank", "on", "X")}
    for d in parts:
        for k in data:
            data[k].append(d[k] + offset if k == "scene" else d[k])
        offset += int(d["scene"].max()) + 1
    out = {k: np.concatenate(v) for k, v in data.items()}
    out["features"] = list(parts[0]["features"])
    return out


def decide(d, prob):
    """Per scene: (best probability, that region on the impurity, visible scene)."""
    prob = np.where(d["rank"] >= 0, prob, -1.0)
    order = np.lexsort((-prob, d["scene"]))
    first = np.r_[True, d["scene"][order][1:] != d["scene"][order][:-1]]
    pick = order[first]
    return prob[pick], d["on"][pick], d["cat"][pick] == "visible"


def tau_at(p, visible, cap):
    clean = np.sort(p[~visible])[::-1]
    allowed = int(np.floor(cap * len(clean)))
    return clean[allowed] + 1e-12 if allowed < len(clean) else -np.inf


def rates(p, on, visible, tau):
    return 100 * np.mean((p[visible] >= tau) & on[visible]), 100 * np.mean(p[~visible] >= tau)


def fit(make, d, cols):
    keep = d["rank"] >= 0
    return make().fit(d["X"][keep][:, cols], d["on"][keep])


def cv(make, d, cols, cap):
    oof = np.zeros(len(d["on"]))
    for tr, te in GroupKFold(n_splits=5).split(d["X"], d["on"], d["palette"]):
        sub = {k: v[tr] for k, v in d.items() if k != "features"}
        model = fit(make, sub, cols)
        oof[te] = model.predict_proba(d["X"][te][:, cols])[:, 1]
    p, on, vis = decide(d, oof)
    return rates(p, on, vis, tau_at(p, vis, cap))


MODELS = {
    "logistic": lambda: make_pipeline(StandardScaler(), LogisticRegression(C=1.0, max_iter=3000)),
    "gbm2": lambda: HistGradientBoostingClassifier(max_depth=2, max_iter=300, learning_rate=0.05),
    "gbm3": lambda: HistGradientBoostingClassifier(max_depth=3, max_iter=200, learning_rate=0.05),
}

if __name__ == "__main__":
    train_sets = ("shared", "own")
    train, fresh = load(*train_sets), load("fresh")
    names = train["features"]
    if len(MODEL.coef) == 5:  # the eighth session's model (the rows' first five features)
        p = MODEL.probability(fresh["X"][:, :5])
        pf, of, vf = decide(fresh, p)
        print(f"shipped model, its threshold {MODEL.threshold:.3f}, on fresh: found %.1f %%, false TARGET "
              "%.1f %%" % rates(pf, of, vf, MODEL.threshold))
    sets = {"shipped 5": names[:5], "all": names} if len(sys.argv) < 2 else {"given": sys.argv[1:]}
    for label, chosen in sets.items():
        cols = [names.index(n) for n in chosen]
        for kind, make in MODELS.items():
            if kind != "logistic" and label == "shipped 5" and False:
                continue
            model = fit(make, train, cols)
            pt, ot, vt = decide(train, model.predict_proba(train["X"][:, cols])[:, 1])
            pf, of, vf = decide(fresh, model.predict_proba(fresh["X"][:, cols])[:, 1])
            line = []
            for cap in (0.01, 0.02, 0.03):
                tau = tau_at(pt, vt, cap)
                line.append("cap %.0f %%: train %.1f/%.1f fresh %.1f/%.1f cv %.1f/%.1f"
                            % (100 * cap, *rates(pt, ot, vt, tau), *rates(pf, of, vf, tau),
                               *cv(make, train, cols, cap)))
            print(f"{label:10s} {kind:9s} " + " | ".join(line), flush=True)
