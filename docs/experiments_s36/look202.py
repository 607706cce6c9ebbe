"""Thirty-sixth session, a diagnostic after mark 1 was read (tuning data): layout random-202 of the shared
layouts, where 10 of C2's 15 false TARGETs fell, in six palettes: the colour heightmap with C2's target mask
outlined (yellow) beside the height map (0-10 cm). Writes docs/experiments_s36/layout202.png.

    python docs/experiments_s36/look202.py
"""
import dataclasses, json, pathlib, sys
import numpy as np, cv2
sys.path.insert(0, "scripts")
import calibrate_attention as ca
from impurity_attention.core.attention import AttentionParams, attend
from impurity_attention.core.verifier import RegionVerifier
net = ca.read_network_option(pathlib.Path("docs/experiments_s35/impurity_net.pt"))
model = RegionVerifier.from_dict(json.loads(pathlib.Path("runs/s36/verifier_c2.json").read_text()))
c2 = dataclasses.replace(AttentionParams(), verifier=model, impurity_net=net, verifier_last_look=0.391)
tiles = []
for r in ca.rule_sweep_records()[0]:
    if r.seed == 202 and r.palette in ("random-14", "random-47", "coal_slate", "random-80", "blocks", "random-3"):
        out = attend(r.color, r.height, c2)
        img = cv2.cvtColor(r.color, cv2.COLOR_RGB2BGR).copy()
        if out.target_mask is not None:
            cnts, _ = cv2.findContours(out.target_mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
            cv2.drawContours(img, cnts, -1, (0, 255, 255), 1)
        h = (np.clip(r.height / 0.1, 0, 1) * 255).astype(np.uint8)
        tiles.append(np.hstack([img, cv2.cvtColor(h, cv2.COLOR_GRAY2BGR)]))
        print(r.palette, r.seed, r.category(), out.mode.name, out.reason[:80])
cv2.imwrite("docs/experiments_s36/layout202.png", np.vstack(tiles))
