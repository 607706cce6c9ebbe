"""Eighth session, tuning data only: a learned region verifier judged by palette-grouped cross-validation
on rule-sweep's scenes (rows from verifier_rows.py). Each fold's palettes are unseen by its model, as
held-out palettes are. Scene decision: the region of the top TOP with the highest probability; TARGET when
it reaches a threshold. found = visible scene, TARGET on a region on the impurity; false = TARGET on a
scene without a visible impurity. Thresholds: (a) the out-of-fold curve's (optimistic, like the grid), (b)
chosen on the training folds' own predictions at the cap and applied to the unseen fold (nested).

    python docs/experiments_s8/verifier_cv.py [feature subset names...]
"""
import sys
import numpy as np
from sklearn.model_selection import GroupKFold
from sklearn.linear_model import LogisticRegression
from sklearn.preprocessing import StandardScaler
from sklearn.pipeline import make_pipeline
from sklearn.ensemble import HistGradientBoostingClassifier

d = np.load("runs/s8_verifier_rows_tuning.npz")
names = list(d["features"])
X, on, scene, pal, cat, rank = d["X"], d["on"], d["scene"], d["palette"], d["cat"], d["rank"]
use = sys.argv[1:] or names
cols = [names.index(n) for n in use]
valid = rank >= 0
scenes = np.unique(scene)
vis_scene = {s: c == "visible" for s, c in zip(scene, cat)}


def decide(prob):
    """per scene: (max prob, whether that region is on target)."""
    best = {}
    for s, p, o, ok in zip(scene, prob, on, valid):
        p = p if ok else -1.0
        if s not in best or p > best[s][0]:
            best[s] = (p, o)
    S = np.array(sorted(best))
    P = np.array([best[s][0] for s in S]); O = np.array([best[s][1] for s in S])
    V = np.array([vis_scene[s] for s in S])
    return S, P, O, V


def curve(P, O, V, caps=(0.01, 0.02, 0.05)):
    out = []
    clean = np.sort(P[~V])[::-1]
    for cap in caps:
        allowed = int(np.floor(cap * len(clean)))
        tau = clean[allowed] + 1e-12 if allowed < len(clean) else -np.inf
        found = np.mean((P[V] >= tau) & O[V]); false = np.mean(P[~V] >= tau)
        out.append(f"<= {100*cap:.0f} %: {100*found:5.1f} % ({100*false:.1f} %)")
    return "   ".join(out)


def tau_at(P, V, cap):
    clean = np.sort(P[~V])[::-1]
    allowed = int(np.floor(cap * len(clean)))
    return clean[allowed] + 1e-12 if allowed < len(clean) else -np.inf


def cv(model_fn, label):
    gkf = GroupKFold(n_splits=5)
    oof = np.zeros(len(X))
    nested = {c: [0, 0, 0, 0] for c in (0.01, 0.02, 0.05)}
    for tr, te in gkf.split(X, on, pal):
        trv = tr[valid[tr]]
        m = model_fn().fit(X[trv][:, cols], on[trv])
        oof[te] = m.predict_proba(X[te][:, cols])[:, 1]
        ptr = m.predict_proba(X[tr][:, cols])[:, 1]
        keep = np.isin(scene, scene[tr])
        # training folds' own decisions
        _, Ptr, _, Vtr = decide_sub(ptr, tr)
        _, Pte, Ote, Vte = decide_sub(oof[te], te)
        for c in nested:
            t = tau_at(Ptr, Vtr, c)
            nested[c][0] += np.sum((Pte[Vte] >= t) & Ote[Vte]); nested[c][1] += Vte.sum()
            nested[c][2] += np.sum(Pte[~Vte] >= t); nested[c][3] += (~Vte).sum()
    S, P, O, V = decide(oof)
    print(f"{label:28s} oof: {curve(P, O, V)}")
    print(f"{'':28s} nested: " + "   ".join(f"<= {100*c:.0f} %: {100*a/b:5.1f} % ({100*f/g:.1f} %)"
                                             for c, (a, b, f, g) in nested.items()))
    return oof


def decide_sub(prob, idx):
    best = {}
    for p, i in zip(prob, idx):
        s = scene[i]
        p = p if valid[i] else -1.0
        if s not in best or p > best[s][0]:
            best[s] = (p, on[i])
    S = np.array(sorted(best))
    return S, np.array([best[s][0] for s in S]), np.array([best[s][1] for s in S]), \
        np.array([vis_scene[s] for s in S])


if __name__ == "__main__":
    print(f"{len(scenes)} scenes, {sum(vis_scene[s] for s in scenes)} visible; features: {', '.join(use)}")
    # the shipped rule on the same rank-0 rows, as a reference
    from impurity_attention.core.attention import AttentionParams, is_target
    r0 = (rank == 0)
    sc = np.exp(X[r0, names.index("log_score")]); co = np.expm1(X[r0, names.index("log_colour")])
    dec = is_target(sc, co, AttentionParams())
    V0 = np.array([vis_scene[s] for s in scene[r0]]); O0 = on[r0]
    nvis = sum(vis_scene[s] for s in scenes); nclean = len(scenes) - nvis
    print(f"shipped rule: found {100*np.sum(dec & O0 & V0)/nvis:.1f} %, false TARGET "
          f"{100*np.sum(dec & ~V0)/nclean:.1f} %")
    cv(lambda: make_pipeline(StandardScaler(), LogisticRegression(C=1.0, max_iter=2000)), "logistic C=1")
    cv(lambda: make_pipeline(StandardScaler(), LogisticRegression(C=0.1, max_iter=2000)), "logistic C=0.1")
    cv(lambda: HistGradientBoostingClassifier(max_depth=3, max_iter=200, learning_rate=0.05), "gbm depth 3")
    cv(lambda: HistGradientBoostingClassifier(max_depth=2, max_iter=300, learning_rate=0.05), "gbm depth 2")
