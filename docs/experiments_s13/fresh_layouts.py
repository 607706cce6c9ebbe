"""Thirteenth session, tuning data only: are the "fresh" tuning palette sets fresh in their layouts?
random-500+, -600+ and -700+ were rendered on the ten visible layouts every tuning palette shares
(PALETTE_PLAN on tuning seeds), layouts the verifier was fitted on under 105 other palettes. Held-out sets
are rendered on acceptance layouts nobody fitted on. Here the same palettes are rendered on layouts of their
own that nothing used: palette k (0-based) gets seeds LAYOUT_SEED_BASE + 800 x the plan's row + k x the
row's count + i (94000 ... 98800, tuning seeds < 100000, unused before). Only measured.

    python docs/experiments_s13/fresh_layouts.py [first] [count]      # default 700 60
"""
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402

LAYOUT_SEED_BASE = 94_000


def own_layout_records(first: int, count: int) -> list:
    """random-<first> ... on layouts of their own (module docstring), cached in
    runs/perception/palettes_fresh<first>_own.npz."""
    palettes = [f"random-{first + number}" for number in range(count)]
    wanted = ca.palette_scenes(palettes,
                               lambda row, number, scenes: LAYOUT_SEED_BASE + 800 * row + number * scenes)
    assert max(seed for *_, seed, _ in wanted) < 100_000  # tuning seeds
    return ca.render_cached(ca.CACHE / f"palettes_fresh{first}_own.npz", wanted,
                            f"fresh tuning palettes {first}+ on their own layouts")


def main() -> None:
    first = int(sys.argv[1]) if len(sys.argv) > 1 else 700
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 60
    records = own_layout_records(first, count)
    print(f"== random-{first} ... {first + count - 1} on layouts of their own (seeds {LAYOUT_SEED_BASE}+)")
    ca.print_palette_rates(ca.palette_rates(records, AttentionParams()))


if __name__ == "__main__":
    main()
