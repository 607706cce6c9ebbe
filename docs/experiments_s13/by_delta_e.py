"""Thirteenth session: found rate by how close the impurity is to the product. Per random palette, the least
CIE76 distance between an impurity colour and a product shade (appearance.delta_e on the palette's colours
as drawn, before light and exposure) and its found count of ten visible scenes; summed per band. Tuning
palettes never fitted on (random-192 ... 391 and random-700 ... 759 on layouts of their own) beside the
held-out set's random palettes (only measured).

    python docs/experiments_s13/by_delta_e.py
"""
import sys

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s12")
sys.path.insert(0, "docs/experiments_s13")
import calibrate_attention as ca  # noqa: E402
import fresh_layouts  # noqa: E402
import more_palettes  # noqa: E402
import set_spread  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402
from ur5_driver_sim.core.appearance import delta_e, palette_named  # noqa: E402

BANDS = ((0, 20), (20, 30), (30, 1000))


def closeness(name: str) -> float:
    palette = palette_named(name)
    return min(delta_e(i, s) for i in palette.impurity_colors for s in palette.product_shades)


def report(title: str, counts: dict) -> None:
    print(f"== {title}: {len(counts)} random palettes")
    for low, high in BANDS:
        chosen = [(f, v) for name, (f, v) in counts.items() if low <= closeness(name) < high]
        found, visible = sum(f for f, _ in chosen), sum(v for _, v in chosen)
        zero = sum(f == 0 for f, _ in chosen)
        band = f"{low}-{high}" if high < 1000 else f"{low}+"
        print(f"  impurity {band:>5} dE from the product: {len(chosen):3d} palettes, "
              f"found {found}/{visible} ({100 * found / max(visible, 1):.1f} %), palettes at 0: {zero}")


def main() -> None:
    params = AttentionParams()
    tuning = set_spread.per_palette(more_palettes.extra_records(200), params)
    tuning.update(set_spread.per_palette(fresh_layouts.own_layout_records(700, 60), params))
    report("tuning, never fitted, own layouts", tuning)
    held_out = set_spread.per_palette(ca.collect_palettes("acceptance"), params)
    report("held-out (eighth set), own layouts",
           {name: counts for name, counts in held_out.items() if name.startswith("random-")})


if __name__ == "__main__":
    main()
