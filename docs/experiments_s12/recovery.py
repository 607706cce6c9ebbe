"""Twelfth session, tuning data only (needs commit 55effa9, taken back after): attention deciding on
clipped views with their highlights recovered
(AttentionParams.recover_highlights, heightmap.recover_highlights) against the camera's colours.

    python docs/experiments_s12/recovery.py exposure 30000 [count_scale]   # default palette, x0.5 / x1 / x2
    python docs/experiments_s12/recovery.py palettes tuning [own]         # tuning palettes, first views
"""
import dataclasses
import sys

sys.path.insert(0, "scripts")
sys.path.insert(0, "docs/experiments_s11")
import calibrate_attention as ca  # noqa: E402
import exposure_wide  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402


def variants() -> list:
    camera = dataclasses.replace(AttentionParams(), recover_highlights=False)
    return [("camera colours", camera),
            ("highlights recovered", dataclasses.replace(camera, recover_highlights=True))]


def main() -> None:
    if sys.argv[1] == "exposure":
        base, scale = int(sys.argv[2]), float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
        records = ca.collect_exposure_scenes(base, scale)
        for name, params in variants():
            print(f"== default palette, {len(records)} scenes, seeds {base}+; {name}", flush=True)
            exposure_wide.report(records, params)
    else:
        records = ca.collect_palettes(sys.argv[2], own_layouts=len(sys.argv) > 3 and sys.argv[3] == "own")
        for name, params in variants():
            print(f"== {sys.argv[2]} palettes{' (own layouts)' if len(sys.argv) > 3 else ''}, {len(records)} "
                  f"scenes; {name}", flush=True)
            ca.print_palette_rates(ca.palette_rates(records, params), per_palette=False)


if __name__ == "__main__":
    main()
