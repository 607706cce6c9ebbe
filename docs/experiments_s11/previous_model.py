"""Eleventh session: the tenth session's shipped verifier (the model of commit 18c266b, every cell compared by
the colour features; shipped again since bc01f7f) through attend(), run while the refit was shipped (6e681af)
to compare: on verifier-fit's shared and own-layout tuning scenes (`fitting`), on the sixth held-out set, the
retired sets and the default palette's exposures (`held-out`), or on exposure_wide.py's scenes (`exposure`).

    python docs/experiments_s11/previous_model.py fitting
    python docs/experiments_s11/previous_model.py held-out
    python docs/experiments_s11/previous_model.py exposure [SEED_BASE [COUNT_SCALE]]  # exposure_wide report
"""
import dataclasses
import subprocess
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import verifier as v  # noqa: E402
from impurity_attention.core.attention import AttentionParams  # noqa: E402

MODEL_FILE = "src/impurity_attention/impurity_attention/core/verifier_model.py"


def previous_params() -> AttentionParams:
    v.MIN_UNCLIPPED_CELLS = 10**9  # every cell compared, as shipped before this session
    source = subprocess.run(["git", "show", f"18c266b:{MODEL_FILE}"], capture_output=True, text=True,
                            check=True).stdout
    namespace = {}
    exec(source.replace("from .verifier import", "from impurity_attention.core.verifier import"), namespace)
    print(f"the tenth session's model, threshold {namespace['MODEL'].threshold}")
    return dataclasses.replace(AttentionParams(), verifier=namespace["MODEL"])


if __name__ == "__main__":
    params = previous_params()
    if sys.argv[1:] == ["fitting"]:
        for half, scenes in (("shared layouts", ca.rule_sweep_records()[0]),
                             ("own layouts", ca.collect_palettes("tuning", own_layouts=True))):
            print(f" shipped (tenth session) verifier, {half}:")
            ca.print_palette_rates(ca.palette_rates(scenes, params), per_palette=False)
    elif sys.argv[1:] == ["held-out"]:
        ca.palette_evaluate(params)
    elif sys.argv[1:2] == ["exposure"] and len(sys.argv) <= 4:
        sys.path.insert(0, "docs/experiments_s11")
        import exposure_wide
        seed_base = int(sys.argv[2]) if len(sys.argv) > 2 else exposure_wide.SEED_BASE
        scale = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
        print(f"== blocks (default), seeds {seed_base}+, scene counts x{scale:g}")
        exposure_wide.report(exposure_wide.collect(scale, seed_base), params)
    else:
        sys.exit(__doc__)
