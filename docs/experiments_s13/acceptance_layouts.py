"""Thirteenth session: are the held-out sets' layouts harder than the tuning ones? Every held-out set so far
was rendered on the same ten visible layouts (PALETTE_PLAN on the acceptance seeds, 1000 + 100 x row + i),
and the seven sets read lower than tuning palettes do on layouts of their own (96.2 % over 260 palettes,
docs/experiments_s13/set_spread.py). Here tuning palettes the verifier never saw, random-700 ... 759, are
rendered on those acceptance layouts and only measured (evaluation seeds: nothing is chosen on them).

    python docs/experiments_s13/acceptance_layouts.py
"""
import sys
from collections import Counter

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402


def main() -> None:
    palettes = [f"random-{seed}" for seed in range(700, 760)]
    wanted = ca.palette_scenes(palettes, lambda row, number, scenes: ca.SEED_BASE["acceptance"] + 100 * row)
    records = ca.render_cached(ca.CACHE / "palettes_fresh700_acceptance_layouts.npz", wanted,
                               "random-700+ on the acceptance layouts")
    print("== random-700 ... 759 on the held-out sets' layouts (acceptance seeds)")
    ca.print_palette_rates(ca.palette_rates(records, AttentionParams()), per_palette=False)
    missed, visible = Counter(), Counter()
    for record in records:
        if record.category() == "visible":
            layout = f"{record.scenario}-{record.seed}"
            visible[layout] += 1
            missed[layout] += not evaluation.judge(record, attend(record.color, record.height,
                                                                  AttentionParams())).success
    for layout in sorted(visible):
        print(f"  {layout:18s} missed {missed[layout]:3d} of {visible[layout]:3d}")


if __name__ == "__main__":
    main()
