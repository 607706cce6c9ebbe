"""Thirteenth session, tuning data only: how precisely does a held-out set of N random palettes measure the
found rate? The shipped attention on 260 random tuning palettes it was never fitted on, each on layouts of
its own: random-192 ... 391 (docs/experiments_s12/more_palettes.py, seeds 80000+) and random-700 ... 759
(docs/experiments_s13/fresh_layouts.py, seeds 94000+). Per palette the found count of its ten visible
scenes; then sets of N palettes drawn from those 260 (with replacement, 20000 draws): the spread of a set's
found rate.

    python docs/experiments_s13/set_spread.py
"""
import sys
from collections import Counter

import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
sys.path.insert(0, "docs/experiments_s13")
import fresh_layouts  # noqa: E402
import more_palettes  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402

DRAWS = 20_000


def per_palette(records, params, hidden: Counter | None = None) -> dict:
    """{palette: (found, visible scenes)}; with `hidden`, its "found" / "scenes" count the invisible scenes
    whose hidden target lies in the chosen heap."""
    found, visible = Counter(), Counter()
    for record in records:
        category = record.category()
        if category not in ("visible", "invisible"):
            continue
        success = evaluation.judge(record, attend(record.color, record.height, params)).success
        if category == "invisible":
            if hidden is not None:
                hidden["scenes"] += 1
                hidden["found"] += success
            continue
        visible[record.palette] += 1
        found[record.palette] += success
    return {p: (found[p], visible[p]) for p in visible}


def main() -> None:
    params = AttentionParams()
    hidden = Counter()
    counts = per_palette(more_palettes.extra_records(200), params, hidden)
    counts.update(per_palette(fresh_layouts.own_layout_records(700, 60), params, hidden))
    found = np.array([f for f, _ in counts.values()], float)
    visible = np.array([v for _, v in counts.values()], float)
    print(f"{len(counts)} palettes, {int(visible.sum())} visible scenes: found {int(found.sum())} "
          f"({100 * found.sum() / visible.sum():.1f} %)")
    print(f"hidden target in the chosen heap: {hidden['found']}/{hidden['scenes']} "
          f"({100 * hidden['found'] / hidden['scenes']:.1f} %)")
    histogram = Counter(int(f) for f in found)
    print("palettes by found of 10: " + ", ".join(f"{k}: {histogram[k]}" for k in sorted(histogram)))
    rng = np.random.default_rng(0)
    for size in (28, 60, 120, 200, 400):
        picks = rng.integers(0, len(found), size=(DRAWS, size))
        rates = 100 * found[picks].sum(axis=1) / visible[picks].sum(axis=1)
        low, high = np.quantile(rates, [0.025, 0.975])
        print(f"  sets of {size:3d} palettes: found {rates.mean():.1f} %, 95 % of sets within {low:.1f} ... "
              f"{high:.1f} %; below 95 %: {100 * np.mean(rates < 95.0):.0f} % of sets; at or below 93.0 %: "
              f"{100 * np.mean(rates <= 93.0):.2f} %; at or below 89.2 %: "
              f"{100 * np.mean(rates <= 89.2):.2f} %; lowest {rates.min():.1f} %")


if __name__ == "__main__":
    main()
