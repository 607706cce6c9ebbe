"""Thirteenth session, tuning palettes only: how much of a palette set's found rate is its layouts? Every
palette of a set is rendered on the same ten visible layouts (calibrate_attention.PALETTE_PLAN on one seed
base), so a layout the attention finds hard counts once per palette. Per set: misses per layout, and the
found rate with each layout left out.

    python docs/experiments_s13/layouts.py 500 600 700
"""
import sys
from collections import Counter

import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
import fresh_tuning_palettes as fresh  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402


def main() -> None:
    params = AttentionParams()
    for first in [int(a) for a in sys.argv[1:]] or [500, 600, 700]:
        visible, missed = Counter(), Counter()
        for record in fresh.fresh_records(first, 60):
            if record.category() != "visible":
                continue
            layout = f"{record.scenario}-{record.seed}"
            visible[layout] += 1
            verdict = evaluation.judge(record, attend(record.color, record.height, params))
            missed[layout] += not verdict.success
        total, misses = sum(visible.values()), sum(missed.values())
        print(f"== random-{first} ... {first + 59}: found {total - misses}/{total} "
              f"({100 * (total - misses) / total:.1f} %)")
        for layout in sorted(visible):
            print(f"  {layout:16s} missed {missed[layout]:3d} of {visible[layout]:3d}")
        shares = [missed[k] / max(misses, 1) for k in visible]
        print(f"  the worst layout holds {100 * max(shares):.0f} % of the misses; the two worst "
              f"{100 * sum(sorted(shares)[-2:]):.0f} %; std of misses over layouts "
              f"{np.std(list(missed.values())):.1f}")


if __name__ == "__main__":
    main()
