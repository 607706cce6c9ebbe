"""Eighth session, tuning data only: every tuning palette on scenes of its own (collect_palettes(own_layouts=
True): 101 palettes x 19 new layouts), against the shared ten layouts everything was chosen on.
The shipped verifier and the rule on both (the verifier was fitted on the shared layouts only; the
refit on both is `calibrate_attention.py verifier-fit --own-layouts`).

    python docs/experiments_s8/own_layouts.py
"""
import sys, collections
sys.path.insert(0, "scripts")
import numpy as np
import calibrate_attention as ca
from impurity_attention.core.attention import AttentionParams

own = ca.collect_palettes("tuning", own_layouts=True)
shared = ca.collect_palettes("tuning")
for name, records in (("shared layouts", shared), ("own layouts", own)):
    for decision in ("rule", "verifier"):
        rates = ca.palette_rates(records, AttentionParams(decision=decision))
        found = np.array([np.mean(v["visible"]) for v in rates.values()])
        print(f"{name}, {decision}: palettes with <= 50 % found {int(np.sum(found <= 0.5))}, <= 80 % "
              f"{int(np.sum(found <= 0.8))} of {len(found)}")
        ca.print_palette_rates(rates, per_palette=False)
