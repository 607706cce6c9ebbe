"""Twelfth session: the criterion for `verifier_clipped_threshold` (docs/experiments.md, twelfth section),
written before these sets were read. Tuning seeds and tuning palettes only.

    python docs/experiments_s12/confirm.py exposure   # fresh default-palette set, seeds 45000+, count_scale 2
    python docs/experiments_s12/confirm.py palettes   # own-layout tuning palettes (palettes_tuning_own)
"""
import dataclasses
import sys

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s11")
import calibrate_attention as ca  # noqa: E402
import exposure_wide  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402

FRESH_SEED_BASE = 45_000  # tuning seeds never rendered before this session's criterion was written
CANDIDATE = 0.8


def variants() -> list:
    shipped = dataclasses.replace(AttentionParams(), verifier_clipped_threshold=0.0)
    return [("threshold on clipped views: as elsewhere (0)", shipped),
            (f"threshold on clipped views: {CANDIDATE}",
             dataclasses.replace(shipped, verifier_clipped_threshold=CANDIDATE))]


def main() -> None:
    if sys.argv[1] == "exposure":
        records = ca.collect_exposure_scenes(FRESH_SEED_BASE, 2.0)
        for name, params in variants():
            print(f"== default palette, {len(records)} scenes, seeds {FRESH_SEED_BASE}+; {name}")
            exposure_wide.report(records, params)
    else:
        records = ca.collect_palettes("tuning", own_layouts=True)
        for name, params in variants():
            print(f"== tuning palettes, own layouts, {len(records)} scenes; {name}")
            ca.print_palette_rates(ca.palette_rates(records, params), per_palette=False)


if __name__ == "__main__":
    main()
