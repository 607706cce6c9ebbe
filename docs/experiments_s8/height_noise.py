"""Eighth session, tuning data only: the two decisions on rule-sweep's scenes with Gaussian noise added to
the height map (a RealSense-like ~2 mm per cell; the projection's own noise handling is not modelled, so
this is harsher than the camera path).

    python docs/experiments_s8/height_noise.py [sigma_m ...]
"""
import sys, dataclasses
sys.path.insert(0, "scripts")
import numpy as np
import calibrate_attention as ca
from impurity_attention.core.attention import AttentionParams

sigmas = [float(v) for v in sys.argv[1:]] or [0.0, 0.001, 0.002]
records, _ = ca.rule_sweep_records()
rng = np.random.default_rng(0)
for sigma in sigmas:
    noisy = []
    for r in records:
        h = r.height + (rng.normal(0, sigma, r.height.shape).astype(np.float32) if sigma else 0)
        h = np.where(r.height > 0, h, r.height)  # the table stays the table
        noisy.append(dataclasses.replace(r, height=h.astype(np.float32)))
    for decision in ("rule", "verifier"):
        print(f"height noise {sigma * 1000:.1f} mm, {decision}:", flush=True)
        ca.print_palette_rates(ca.palette_rates(noisy, AttentionParams(decision=decision)), per_palette=False)
