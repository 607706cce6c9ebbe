"""Tenth session, tuning seeds only: the default palette's tuning scenes (seeds 0..99) at exposure x0.5 / x1 /
x2 through the shipped attention: does overexposure raise false TARGETs on scenes nothing is measured on?

    python docs/experiments_s10/exposure_tuning.py
"""
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402

default = [r for r in ca.collect("tuning") if r.category() in ("visible", "no_impurity")]
for exposure in ca.EXPOSURES:
    print(f"== default palette, tuning seeds, exposure x{exposure:g}")
    ca.print_palette_rates(ca.palette_rates([r.exposed(exposure) for r in default], AttentionParams()),
                           per_palette=False)
