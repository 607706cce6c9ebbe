"""Thirteenth session, tuning palettes only: where the shipped attention loses impurities within 20 dE of the
product (docs/experiments_s13/by_delta_e.py: 90.6 % found on tuning palettes never fitted, 81.8 % on the
eighth held-out set). For the close random palettes among random-192 ... 391 and random-700 ... 759 (layouts
of their own): per visible scene the outcome as candidates.py tells it. A starting point for the next
change, which is to be judged on a ninth held-out set.

    python docs/experiments_s13/close_misses.py
"""
import sys
from collections import Counter

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
sys.path.insert(0, "docs/experiments_s13")
import by_delta_e  # noqa: E402
import candidates  # noqa: E402
import fresh_layouts  # noqa: E402
import more_palettes  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402


def main() -> None:
    params = AttentionParams()
    records = more_palettes.extra_records(200) + fresh_layouts.own_layout_records(700, 60)
    close = [r for r in records if r.palette.startswith("random-") and by_delta_e.closeness(r.palette) < 20
             and r.category() == "visible"]
    outcomes = Counter(candidates.outcome(r, params) for r in close)
    print(f"{len(close)} visible scenes of {len({r.palette for r in close})} random tuning palettes with an "
          f"impurity within 20 dE of the product:")
    for outcome, count in outcomes.most_common():
        print(f"  {count:4d}  {outcome}")
    missed = len(close) - outcomes["found"]
    not_taken = sum(count for outcome, count in outcomes.items() if outcome.startswith("candidate"))
    print(f"  found: {100 * outcomes['found'] / len(close):.1f} %; of the {missed} misses, the impurity is a "
          f"candidate not taken in {not_taken}")


if __name__ == "__main__":
    main()
