"""Thirty-sixth session, a diagnostic after mark 1 was read (tuning data; nothing chosen by it): which scenes
without an impurity of the verifier fit's shared layouts (rule-sweep's records) get a TARGET from the shipped
cell (S) and from C2 (docs/experiments_s36/match_thresholds.py's model and last look), and why.

    python docs/experiments_s36/false_targets.py > docs/experiments_s36/false_targets.txt
"""
import dataclasses, json, pathlib, sys
sys.path.insert(0, "scripts")
import calibrate_attention as ca
from impurity_attention.core import evaluation
from impurity_attention.core.attention import AttentionParams, attend
from impurity_attention.core.verifier import RegionVerifier
net = ca.read_network_option(pathlib.Path("docs/experiments_s35/impurity_net.pt"))
model = RegionVerifier.from_dict(json.loads(pathlib.Path("runs/s36/verifier_c2.json").read_text()))
c2 = dataclasses.replace(AttentionParams(), verifier=model, impurity_net=net, verifier_last_look=0.391)
s = AttentionParams()
for r in ca.rule_sweep_records()[0]:
    if r.category() == "visible":
        continue
    for name, p in (("S", s), ("C2", c2)):
        out = attend(r.color, r.height, p)
        if out.mode.name == "TARGET":
            print(name, r.palette, r.scenario, r.seed, r.category(), "last_look" if out.last_look else "main", out.reason[:90], flush=True)
