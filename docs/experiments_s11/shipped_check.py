"""Eleventh session: the tenth session's shipped verifier (the model of commit 18c266b, every cell compared by
the colour features) through attend() on verifier-fit's shared and own-layout tuning scenes.

    python docs/experiments_s11/shipped_check.py
"""
import dataclasses
import subprocess
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import verifier as v  # noqa: E402
from impurity_attention.core.attention import AttentionParams  # noqa: E402

v.MIN_UNCLIPPED_CELLS = 10**9  # every cell compared, as shipped before this session
MODEL_FILE = "src/impurity_attention/impurity_attention/core/verifier_model.py"
source = subprocess.run(["git", "show", f"18c266b:{MODEL_FILE}"], capture_output=True, text=True,
                        check=True).stdout
namespace = {}
exec(source.replace("from .verifier import", "from impurity_attention.core.verifier import"), namespace)
model = namespace["MODEL"]
print(model.threshold)
params = dataclasses.replace(AttentionParams(), verifier=model)
for half, scenes in (("shared layouts", ca.rule_sweep_records()[0]),
                     ("own layouts", ca.collect_palettes("tuning", own_layouts=True))):
    print(f" shipped (tenth session) verifier, {half}:")
    ca.print_palette_rates(ca.palette_rates(scenes, params), per_palette=False)
