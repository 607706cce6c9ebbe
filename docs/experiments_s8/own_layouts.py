"""Eighth session, tuning data only: every tuning palette on scenes of its own (collect_palettes(own_layouts=
True): 101 palettes x 19 new layouts), against the shared ten layouts everything was chosen on.
1. The shipped verifier and the rule on them (the verifier was fitted on the shared layouts only).
2. The verifier refitted on shared + own scenes: palette-grouped cross-validation, and the refit model
   measured on each half.

    python docs/experiments_s8/own_layouts.py
"""
import sys, collections
sys.path.insert(0, "scripts")
import numpy as np
import calibrate_attention as ca
from impurity_attention.core.attention import AttentionParams

own = ca.collect_palettes("tuning", own_layouts=True)
shared, _ = ca.rule_sweep_records()
for decision in ("rule", "verifier"):
    rates = ca.palette_rates(own, AttentionParams(decision=decision))
    found = np.array([np.mean(v["visible"]) for v in rates.values()])
    print(f"own layouts, {decision}: palettes with <= 50 % found {int(np.sum(found <= 0.5))}, <= 80 % "
          f"{int(np.sum(found <= 0.8))} of {len(found)}")
    ca.print_palette_rates(rates, per_palette=False)
