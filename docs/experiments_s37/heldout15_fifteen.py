"""Thirty-seventh session, after the fifteenth held-out set's reading (decides nothing): the same 2000 + 1200
held-out scenes (palette-evaluate's records of splits.held_out_palettes(), cached by that run) read through
attend() with the fifteen-feature verifier the cell shipped before the network (verifier_model.py at 124557a,
threshold 0.813, last look 0.52), beside the shipped cell; a paired reading of what the network changed on
palettes nobody tuned on. Only measured.

    python docs/experiments_s37/heldout15_fifteen.py
"""
import dataclasses
import subprocess
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402
from impurity_attention.core.verifier import RegionVerifier  # noqa: E402

BEFORE = "124557a"  # the last commit with the fifteen-feature verifier shipped


def fifteen_feature_model() -> RegionVerifier:
    """verifier_model.py's MODEL at BEFORE, executed with this tree's RegionVerifier."""
    source = subprocess.run(["git", "show", f"{BEFORE}:src/impurity_attention/impurity_attention/core/"
                             "verifier_model.py"], capture_output=True, text=True, check=True).stdout
    namespace = {"RegionVerifier": RegionVerifier}
    exec(source.replace("from .verifier import RegionVerifier", ""), namespace)  # noqa: S102 - our history
    return namespace["MODEL"]


def main() -> None:
    records = ca.collect_palettes("acceptance")
    before = dataclasses.replace(AttentionParams(), verifier=fifteen_feature_model(), verifier_last_look=0.52)
    for name, params in (("shipped (network)", AttentionParams()), (f"fifteen features ({BEFORE})", before)):
        print(f"== {name}", flush=True)
        ca.print_palette_rates(ca.palette_rates(records, params), per_palette=False)


if __name__ == "__main__":
    main()
