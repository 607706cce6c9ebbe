"""Thirty-third session, tuning data only: a check set for a refitted verifier, never fitted on.

random-400 ... 599 (tuning palettes; random-500+ were measured, never fitted on, in the thirteenth session and
drawn in earlier picking tests) on layouts of their own that nothing used: palette k (0-based) gets seeds
LAYOUT_SEED_BASE + 1400 x PALETTE_PLAN's row + k x the row's count + i (61 000 ... 69 599, tuning seeds,
registered in impurity_learning.splits). Reads found / false TARGET / hidden target in the chosen heap
through attend() for the shipped verifier and for each model given (JSON of RegionVerifier's fields, as
`calibrate_attention.py verifier-fit --model-json` writes them).

    python docs/experiments_s33/check_palettes.py [model.json ...] [--last-look T ...] [--network W]

Another check set (thirty-seventh session): --random-from N --count K --layout-seed-base B --packed reads
random-N ... N + K - 1 (tuning palettes: splits.palette_group) on layouts of their own, PALETTE_PLAN's rows
packed one after the other from B (palette k's scenes of a row follow palette k - 1's).
"""
import argparse
import dataclasses
import json
import pathlib
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402
from impurity_attention.core.verifier import RegionVerifier, default_verifier  # noqa: E402

LAYOUT_SEED_BASE = 61_000
FIRST, COUNT = 400, 200


def check_records(first: int = FIRST, count: int = COUNT, seed_base: int = LAYOUT_SEED_BASE,
                  packed: bool = False) -> list:
    """The check set's scene records (rendered once, cached in runs/perception/palettes_check400_own.npz;
    another set in palettes_check<first>_<count>_<seed_base>.npz). Raises ValueError if a palette is not a
    tuning palette (splits.tuning_random_palettes), SystemExit if no block of splits.TUNING_SEED_BLOCKS holds
    the seeds."""
    from impurity_learning import splits

    palettes = splits.tuning_random_palettes(first, count)
    if packed:
        wanted = ca.palette_scenes(palettes, ca.packed_layouts(seed_base, count))
    else:
        wanted = ca.palette_scenes(palettes,
                                   lambda row, number, scenes: seed_base + 1400 * row + number * scenes)
    last = max(seed for *_, seed, _ in wanted)
    if not any(block.start <= seed_base and last < block.stop for block in splits.TUNING_SEED_BLOCKS):
        raise SystemExit(f"seeds {seed_base} ... {last}: no registered block holds them "
                         "(splits.TUNING_SEED_BLOCKS)")
    name = (f"palettes_check{first}_own.npz" if (first, count, seed_base, packed) == (FIRST, COUNT,
                                                                                      LAYOUT_SEED_BASE, False)
            else f"palettes_check{first}_{count}_{seed_base}{'_packed' if packed else ''}.npz")
    return ca.render_cached(ca.CACHE / name, wanted, f"check palettes {first}+ on their own layouts")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("models", nargs="*", type=pathlib.Path)
    parser.add_argument("--last-look", type=float, nargs="*", default=[],
                        help="each model's verifier_last_look (default: the shipped one)")
    parser.add_argument("--network", type=pathlib.Path, default=None,
                        help="the impurity network the models reading its features run on (a weights file; "
                             "default: the shipped one)")
    parser.add_argument("--random-from", type=int, default=FIRST, help="the first palette, random-<N>")
    parser.add_argument("--count", type=int, default=COUNT, help="how many palettes")
    parser.add_argument("--layout-seed-base", type=int, default=LAYOUT_SEED_BASE,
                        help="the first layout seed (a block of splits.TUNING_SEED_BLOCKS)")
    parser.add_argument("--packed", action="store_true", help="PALETTE_PLAN's rows packed one after the other")
    args = parser.parse_args()
    records = check_records(args.random_from, args.count, args.layout_seed_base, args.packed)
    network = ca.read_network_option(args.network)
    arms = [("shipped", AttentionParams())]
    for k, path in enumerate(args.models):
        params = AttentionParams(verifier=RegionVerifier.from_dict(json.loads(path.read_text())),
                                 impurity_net=network)
        if k < len(args.last_look):
            params = dataclasses.replace(params, verifier_last_look=args.last_look[k])
        arms.append((str(path), params))
    for name, params in arms:
        threshold = (params.verifier or default_verifier()).threshold
        print(f"== {name} (threshold {threshold:.3f}, last look {params.verifier_last_look})", flush=True)
        ca.print_palette_rates(ca.palette_rates(records, params), per_palette=False)


if __name__ == "__main__":
    main()
