"""Seventh session, tuning data only: which tuning palettes' first views heightmap.exposure_problem flags (and the
default palette's tuning scenes at exposure x1 and x2),
beside how many of their visible impurities the shipped attention rule finds.

    python docs/experiments_s7/exposure_flags.py
"""
import collections
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402
from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402
from impurity_attention.core.heightmap import exposure_problem  # noqa: E402

params = AttentionParams()
flagged, scenes, found, visible = (collections.Counter() for _ in range(4))
for record in ca.collect_palettes("tuning"):
    scenes[record.palette] += 1
    flagged[record.palette] += exposure_problem(record.color, record.height) is not None
    if record.category() == "visible":
        visible[record.palette] += 1
        found[record.palette] += evaluation.judge(record, attend(record.color, record.height, params)).success
hard = {p for p in visible if found[p] < visible[p] / 2}
flagged_palettes = {p for p in scenes if flagged[p] > scenes[p] / 2}
print(f"{len(flagged_palettes)} of {len(scenes)} palettes flagged in most of their scenes; palettes where "
      f"fewer than half the impurities are found: {len(hard)}, flagged among them: {len(hard & flagged_palettes)}")
for p in sorted(flagged_palettes | hard, key=lambda p: found[p] / max(visible[p], 1)):
    print(f"  {p:16s} flagged {flagged[p]:2d}/{scenes[p]:2d}  found {found[p]:2d}/{visible[p]:2d}")
default = ca.collect("tuning")  # the default palette's tuning scenes
for exposure in (1.0, 2.0):
    shown = [r if exposure == 1.0 else r.exposed(exposure) for r in default]
    flagged_default = sum(exposure_problem(r.color, r.height) is not None for r in shown)
    print(f"default palette x{exposure:g}: flagged in {flagged_default} of {len(shown)} tuning scenes")
