"""Eighth session, tuning data only: greedy forward selection of the logistic verifier's features by
palette-grouped cross-validation (verifier_cv.py's out-of-fold found at <= 1 % and <= 2 % false TARGET,
their mean).

    python docs/experiments_s8/verifier_select.py
"""
import numpy as np
from sklearn.model_selection import GroupKFold
from sklearn.linear_model import LogisticRegression
from sklearn.preprocessing import StandardScaler
from sklearn.pipeline import make_pipeline
import verifier_cv as vc

def score(cols):
    oof = np.zeros(len(vc.X))
    for tr, te in GroupKFold(n_splits=5).split(vc.X, vc.on, vc.pal):
        trv = tr[vc.valid[tr]]
        m = make_pipeline(StandardScaler(), LogisticRegression(C=1.0, max_iter=3000)).fit(vc.X[trv][:, cols], vc.on[trv])
        oof[te] = m.predict_proba(vc.X[te][:, cols])[:, 1]
    S, P, O, V = vc.decide(oof)
    res = []
    for cap in (0.01, 0.02):
        t = vc.tau_at(P, V, cap)
        res.append(np.mean((P[V] >= t) & O[V]))
    return res

chosen, left = [], list(range(len(vc.names)))
while left:
    trials = [(np.mean(score(chosen + [c])), c) for c in left]
    best, c = max(trials)
    chosen.append(c); left.remove(c)
    r = score(chosen)
    print(f"{len(chosen):2d} + {vc.names[c]:16s} <=1 %: {100*r[0]:.1f}  <=2 %: {100*r[1]:.1f}", flush=True)
