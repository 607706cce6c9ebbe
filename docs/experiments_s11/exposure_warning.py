"""Eleventh session: does the heightmap node's exposure warning (heightmap.exposure_problem) fire on the
default palette's exposure check scenes (tuning seeds 30000+) at x0.5, x1 and x2?

    python docs/experiments_s11/exposure_warning.py
"""
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.heightmap import exposure_problem  # noqa: E402

records = ca.collect_exposure_scenes(ca.EXPOSURE_CHECK_SEED_BASE)
for exposure in ca.EXPOSURES:
    flagged = sum(exposure_problem(r.exposed(exposure).color, r.height) is not None for r in records)
    print(f"x{exposure:g}: exposure warning on {flagged}/{len(records)} tuning scenes")
print("for example:", exposure_problem(records[0].exposed(2.0).color, records[0].height))
