"""Thirty-third session, tuning data only: the shipped verifier's threshold at another false-TARGET cap.

The shipped threshold is the least that lets VERIFIER_FALSE_TARGET (1 %) of the fitting first views without
a visible impurity through (scripts/calibrate_attention.py verifier_fit with --own-layouts --threshold-on
first-views: rule-sweep's scenes and the tuning palettes' own-layout scenes). This reads the shipped model's
probabilities on those same views and prints the threshold at 1 % (which must give the shipped one) and at
the cap asked; with --model-json it writes the shipped model with that threshold (RegionVerifier's fields as
JSON, what push_out.py --verifier and exposure_wide.py --model read).

    python docs/experiments_s33/cap_threshold.py 0.02 [--model-json runs/s33/verifier_cap2.json]
"""
import argparse
import dataclasses
import json
import pathlib
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core.attention import AttentionParams  # noqa: E402
from impurity_attention.core.verifier import default_verifier  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("cap", type=float, help="share of the clean first views let through, e.g. 0.02")
    parser.add_argument("--model-json", type=pathlib.Path, default=None)
    args = parser.parse_args()
    records, _ = ca.rule_sweep_records()
    records = records + ca.collect_palettes("tuning", own_layouts=True)
    model = default_verifier()
    features, on, scene, _, visible = ca.verifier_rows(records, AttentionParams())
    best, hit = ca.scene_decisions(model.probability(features), on, scene, len(visible))
    print(f"{len(visible)} first views ({int(visible.sum())} with a visible impurity), "
          f"{len(features)} regions")
    for cap in sorted({ca.VERIFIER_FALSE_TARGET, args.cap}):
        least = ca.threshold_at(best, visible, cap)
        taken = best >= least
        print(f"cap {100 * cap:.1f} %: threshold {least:.6f}; on these views found "
              f"{100 * (taken & hit)[visible].mean():.2f} %, "
              f"false TARGET {100 * taken[~visible].mean():.2f} %")
    print(f"shipped threshold {model.threshold:.6f}")
    if args.model_json:
        chosen = dataclasses.replace(
            model, threshold=round(ca.threshold_at(best, visible, args.cap), 6),
            provenance=f"{model.provenance}; threshold at a {100 * args.cap:g} % cap "
                       "(docs/experiments_s33/cap_threshold.py)")
        args.model_json.parent.mkdir(parents=True, exist_ok=True)
        args.model_json.write_text(json.dumps(dataclasses.asdict(chosen), indent=1))
        print(f"wrote {args.model_json}")


if __name__ == "__main__":
    main()
