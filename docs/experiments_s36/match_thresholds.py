"""Thirty-sixth session, tuning data only: the network cell's thresholds matched to the shipped cell's.

The shipped cell (S) decides with three verifier thresholds chosen on S's probabilities: the main one (the
model's own, 0.813), the last look (AttentionParams.verifier_last_look, 0.52) and the stall look
(AttentionParams.stall_look_threshold, 0.25). The thirty-fifth session's candidate (C: the impurity network
and the verifier refitted with it, docs/experiments_s35/) moved the probabilities, and its last look, chosen by
the tenth section's rule on 9 views, fell to 0.07. Here each of C's three thresholds is instead the least one
that lets through no more scenes without a visible impurity than S's lets through at S's value, both read on
the same tuning scenes: the verifier fit's own (rule-sweep's shared layouts, the tuning palettes' own layouts
and the shipped cell's picking-loop views, runs/s34/views_*.npz), each scene's likeliest region as attend()
scores it (calibrate_attention.verifier_rows, scene_decisions). Rounded up to 0.001.

Writes C's model with the matched main threshold as JSON (--out) and the last and stall looks to
--thresholds (``last_look T`` / ``stall_look T`` lines). With --check: the verifier fit's check through
attend() on the first views (shared and own layouts) with the matched thresholds (the criterion's mark 1).

    python docs/experiments_s36/match_thresholds.py docs/experiments_s35/verifier_net.json \
        docs/experiments_s35/impurity_net.pt runs/s34/views_*.npz --out runs/s36/verifier_c2.json \
        --thresholds runs/s36/thresholds.txt --check
"""
import argparse
import dataclasses
import json
import math
import pathlib
import sys

import numpy as np

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams  # noqa: E402
from impurity_attention.core.verifier import RegionVerifier, default_verifier  # noqa: E402


def matched(best_shipped: np.ndarray, best_candidate: np.ndarray, clean: np.ndarray, shipped_t: float) -> tuple:
    """(the candidate's threshold, how many clean scenes S lets through at shipped_t, how many the candidate
    lets through at its threshold): the least threshold, rounded up to 0.001, at which the candidate lets
    through at most as many clean scenes as S does at shipped_t."""
    allowed = int(np.sum(best_shipped[clean] >= shipped_t))
    exact = ca.threshold_letting_through(best_candidate, ~clean, allowed)
    threshold = math.ceil(exact * 1000) / 1000
    return threshold, allowed, int(np.sum(best_candidate[clean] >= threshold))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("model", type=pathlib.Path, help="C's verifier (verifier-fit --model-json)")
    parser.add_argument("network", type=pathlib.Path, help="C's impurity network (weights file)")
    parser.add_argument("views", type=pathlib.Path, nargs="+", help="picking-loop views (.npz)")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="C's model, matched main threshold")
    parser.add_argument("--thresholds", type=pathlib.Path, required=True)
    parser.add_argument("--check", action="store_true", help="mark 1: attend() on the first views")
    args = parser.parse_args()
    shipped, candidate = default_verifier(), RegionVerifier.from_dict(json.loads(args.model.read_text()))
    network = ca.read_network_option(args.network)
    base = AttentionParams()
    halves = {"shared layouts": ca.rule_sweep_records()[0],
              "own layouts": ca.collect_palettes("tuning", own_layouts=True),
              "picking-loop views": [r for path in args.views for r in evaluation.load_records(path)]}
    records = [r for half in halves.values() for r in half]
    features, on, scene, _, visible = ca.verifier_rows(records, base, network)
    count = len(visible)
    best_s, hit_s = ca.scene_decisions(shipped.probability(features), on, scene, count)
    best_c, hit_c = ca.scene_decisions(candidate.probability(features), on, scene, count)
    clean = ~visible
    print(f"{count} tuning scenes ({int(visible.sum())} with a visible impurity, {int(clean.sum())} without), "
          f"{len(features)} regions; S {len(shipped.features)} features, C {len(candidate.features)}")
    chosen = {}
    for name, shipped_t in (("main", shipped.threshold), ("last_look", base.verifier_last_look),
                            ("stall_look", base.stall_look_threshold)):
        threshold, allowed, taken = matched(best_s, best_c, clean, shipped_t)
        chosen[name] = threshold
        found_s = np.mean((best_s >= shipped_t)[visible] & hit_s[visible])
        found_c = np.mean((best_c >= threshold)[visible] & hit_c[visible])
        print(f"{name:10s} S {shipped_t:.3f}: {allowed} clean scenes through, likeliest region found "
              f"{100 * found_s:.2f} %;  C {threshold:.3f}: {taken} through, found {100 * found_c:.2f} %")
    model = dataclasses.replace(candidate, threshold=chosen["main"],
                                provenance=candidate.provenance + "; threshold matched to the shipped model's "
                                "false TARGETs (docs/experiments_s36/match_thresholds.py)")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(dataclasses.asdict(model), indent=1))
    args.thresholds.write_text(f"last_look {chosen['last_look']}\nstall_look {chosen['stall_look']}\n")
    print(f"wrote {args.out} (threshold {chosen['main']}) and {args.thresholds}")
    if args.check:
        params = dataclasses.replace(base, verifier=model, impurity_net=network,
                                     verifier_last_look=chosen["last_look"])
        print("checked through attend() (C, matched thresholds):")
        for half in ("shared layouts", "own layouts"):
            print(f" {half}:")
            ca.print_palette_rates(ca.palette_rates(halves[half], params), per_palette=False)


if __name__ == "__main__":
    main()
