"""Seventh session: of the visible scenes a per-cell colour oracle separates (evaluation.colour_separable),
how many the shipped rule finds; per split (tuning palettes, or the acceptance renders: the third set and
the retired ones).

    python docs/experiments_s7/found_given_separable.py tuning|acceptance|retired
"""
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402
from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402

params = AttentionParams()
counts = {(s, f): 0 for s in (True, False) for f in (True, False)}
for record in ca.collect_palettes(sys.argv[1]):
    separable = evaluation.colour_separable(record)
    if separable is None:
        continue
    found = evaluation.judge(record, attend(record.color, record.height, params)).success
    counts[(separable, bool(found))] += 1
sep = counts[(True, True)] + counts[(True, False)]
print(f"{sys.argv[1]}: separable {sep}, found among them {counts[(True, True)]} "
      f"({100 * counts[(True, True)] / max(sep, 1):.1f} %); not separable {counts[(False, True)] + counts[(False, False)]}, "
      f"found among them {counts[(False, True)]}")
