"""Thirty-third session, tuning data only: a check set for a refitted verifier, never fitted on.

random-400 ... 599 (tuning palettes; random-500+ were measured, never fitted on, in the thirteenth session and
drawn in earlier picking tests) on layouts of their own that nothing used: palette k (0-based) gets seeds
LAYOUT_SEED_BASE + 1400 x PALETTE_PLAN's row + k x the row's count + i (61 000 ... 69 599, tuning seeds,
registered in impurity_learning.splits). Reads found / false TARGET / hidden target in the chosen heap
through attend() for the shipped verifier and for each model given (JSON of RegionVerifier's fields, as
`calibrate_attention.py verifier-fit --model-json` writes them).

    python docs/experiments_s33/check_palettes.py [model.json ...] [--last-look T ...]
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


def check_records() -> list:
    """The check set's scene records (rendered once, cached in runs/perception/palettes_check400_own.npz)."""
    palettes = [f"random-{FIRST + number}" for number in range(COUNT)]
    wanted = ca.palette_scenes(palettes,
                               lambda row, number, scenes: LAYOUT_SEED_BASE + 1400 * row + number * scenes)
    assert max(seed for *_, seed, _ in wanted) < 70_000  # the registered block
    return ca.render_cached(ca.CACHE / f"palettes_check{FIRST}_own.npz", wanted,
                            f"check palettes {FIRST}+ on their own layouts")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("models", nargs="*", type=pathlib.Path)
    parser.add_argument("--last-look", type=float, nargs="*", default=[],
                        help="each model's verifier_last_look (default: the shipped one)")
    args = parser.parse_args()
    records = check_records()
    arms = [("shipped", AttentionParams())]
    for k, path in enumerate(args.models):
        params = AttentionParams(verifier=RegionVerifier.from_dict(json.loads(path.read_text())))
        if k < len(args.last_look):
            params = dataclasses.replace(params, verifier_last_look=args.last_look[k])
        arms.append((str(path), params))
    for name, params in arms:
        threshold = (params.verifier or default_verifier()).threshold
        print(f"== {name} (threshold {threshold:.3f}, last look {params.verifier_last_look})", flush=True)
        ca.print_palette_rates(ca.palette_rates(records, params), per_palette=False)


if __name__ == "__main__":
    main()
