"""Ninth session, tuning data only: greedy forward selection of the logistic verifier's features by
palette-grouped 5-fold cross-validation on the shared and own-layout tuning scenes (models.py's cv: found at
<= 1 % and <= 2 % false TARGET, their mean), printing beside each step what the same model fitted on all the
training scenes does on the fresh tuning palettes at the training scenes' 1 % and 2 % thresholds.

    cd docs/experiments_s9 && python forward_select.py
"""
import numpy as np

import models as m

train, fresh = m.load("shared", "own"), m.load("fresh")
names = train["features"]
make = m.MODELS["logistic"]


def fresh_rates(cols, cap):
    model = m.fit(make, train, cols)
    pt, ot, vt = m.decide(train, model.predict_proba(train["X"][:, cols])[:, 1])
    pf, of, vf = m.decide(fresh, model.predict_proba(fresh["X"][:, cols])[:, 1])
    return m.rates(pf, of, vf, m.tau_at(pt, vt, cap))


chosen, left = [], list(range(len(names)))
while left:
    trials = [(np.mean([m.cv(make, train, chosen + [c], cap)[0] for cap in (0.01, 0.02)]), c) for c in left]
    best, c = max(trials)
    chosen.append(c)
    left.remove(c)
    cv1, cv2 = (m.cv(make, train, chosen, cap) for cap in (0.01, 0.02))
    f1, f2 = fresh_rates(chosen, 0.01), fresh_rates(chosen, 0.02)
    print(f"{len(chosen):2d} + {names[c]:18s} cv <=1 %: {cv1[0]:.1f} ({cv1[1]:.1f})  <=2 %: {cv2[0]:.1f} "
          f"({cv2[1]:.1f})   fresh at 1 %: {f1[0]:.1f} ({f1[1]:.1f})  at 2 %: {f2[0]:.1f} ({f2[1]:.1f})",
          flush=True)
