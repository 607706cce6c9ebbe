"""Twenty-first session, tuning data only: the last look's threshold for a refitted verifier.

The last look (AttentionParams.verifier_last_look) attends the verifier's likeliest region as a TARGET when
attention would answer NONE and no heap could hide an impurity. Its 0.35 was chosen (tenth section of
docs/experiments.md) on that session's model's probabilities; a refit moves them. This reads loop views
(docs/experiments_s17/loop_views.py) with a model that was not fitted on them: every view where attention
with the model answers NONE with no heap left, its likeliest region's probability, and whether that region
lies on a visible target ("impurity"), off every target while one is visible ("off target"), or in a view
showing none ("clean"). Then the rule of the tenth section: t is the middle of the widest run of thresholds
(0.01 steps) that takes no clean view and the most impurities.

    python docs/experiments_s21/last_look.py runs/s21/verifier_even.json runs/s21/views_odd.npz
"""
import argparse
import pathlib
import re
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "experiments_s14"))
import push_out  # noqa: E402

PROBABILITY = re.compile(r"impurity probability ([0-9.]+) >=")
GRID = np.round(np.arange(0.01, 1.0, 0.01), 2)


def last_look_views(records, model) -> list:
    """[(probability, kind)] of the views where the last look would decide (module docstring)."""
    import dataclasses

    from impurity_attention.core.attention import AttentionParams, attend
    params = dataclasses.replace(AttentionParams(), verifier=model, verifier_last_look=1e-6)
    looks = []
    for record in records:
        output = attend(record.color, record.height, params)
        if not output.last_look:
            continue
        probability = float(PROBABILITY.search(output.reason).group(1))
        if record.category() != "visible":
            kind = "clean"
        elif np.any(output.target_mask & record.visible_target_cells):
            kind = "impurity"
        else:
            kind = "off target"
        looks.append((probability, kind))
    return looks


def choose(looks) -> tuple:
    """(t, table): the middle of the widest run of GRID thresholds taking no clean view and the most
    impurities; table rows (t, impurities, off target, clean) taken from t on."""
    p = np.array([x for x, _ in looks])
    kinds = np.array([k for _, k in looks])
    table = [(t, *(int(np.sum((p >= t) & (kinds == kind))) for kind in ("impurity", "off target", "clean")))
             for t in GRID]
    quiet = [row for row in table if row[3] == 0]
    if not quiet:
        return None, table
    most = max(row[1] for row in quiet)
    runs, current = [], []
    for row in table:
        if row[3] == 0 and row[1] == most:
            current.append(row[0])
        elif current:
            runs.append(current)
            current = []
    if current:
        runs.append(current)
    widest = max(runs, key=len)
    return float(np.round((widest[0] + widest[-1]) / 2, 2)), table


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="a RegionVerifier as JSON (verifier-fit --model-json)")
    parser.add_argument("views", nargs="+", help="loop views (.npz) the model was not fitted on")
    args = parser.parse_args(argv)
    from impurity_attention.core import evaluation
    records = [r for path in args.views for r in evaluation.load_records(path)]
    looks = last_look_views(records, push_out.verifier_from_json(args.model))
    counts = {kind: sum(k == kind for _, k in looks) for kind in ("impurity", "off target", "clean")}
    print(f"{len(records)} views; the last look decides on {len(looks)}: {counts}")
    t, table = choose(looks)
    print("t  impurities  off_target  clean  (taken from t on)")
    for row in table[::5]:
        print(f"{row[0]:.2f} {row[1]:4d} {row[2]:4d} {row[3]:4d}")
    print(f"chosen t = {t}" if t is not None else "no threshold takes no clean view")
    return 0


if __name__ == "__main__":
    sys.exit(main())
