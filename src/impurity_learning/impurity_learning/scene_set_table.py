"""One table across scene sets: eval_cli runs with --scene-set (each its results.json), the same episodes
counted by perception (as a real cell counts) and by the simulator's truth, per set, scenario and row.

    python -m impurity_learning.scene_set_table runs/eval/*-tuning/results.json

Per row (and palette group: a run's other groups, e.g. held-out palettes, on rows of their own):
episodes; actions per scene and grasp success by perception and by truth (means with 95 % t intervals;
grasp success by perception is counted by the truth recorded beside); how the perception-counted episodes
ended (the cell's own "nothing left" / the action limit / otherwise); impurities
left behind and product lifted per scene, by the truth recorded beside. A set without impurities (clean)
is read from its clean scenes.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

from .perception_figures import ENDINGS, counted_groups, shown


def table_rows(results: dict) -> list:
    """[(scene set, split, row, scenario, figures)] of one eval_cli results.json (row: the row key, with
    " · <group>" for a palette group other than the default); figures: episodes, actions and grasp_success
    by perception and truth_actions, truth_grasp_success by truth (mean_interval dicts; grasp success None
    on clean scenes), ended ({ENDINGS: episodes}), left and product_lifted (mean_interval dicts; left None on
    clean scenes)."""
    meta = results["_meta"]
    out = []
    for row in meta["rows"]:
        entry = results[row]
        if entry.get("missing"):
            continue
        for group, by_perception in counted_groups(entry):
            truths = entry["scenarios"] if group == "default" else entry["groups"][group]
            name = row if group == "default" else f"{row} · {group}"
            for scenario in meta["scenarios"]:
                counted = by_perception["scenarios"][scenario]
                clean = not counted["episodes"]
                if clean:
                    counted = by_perception["clean_scenes"][scenario]
                if not counted["episodes"]:
                    continue
                truth = truths[scenario]
                out.append((meta.get("scene_set", "paper"), meta.get("split", "evaluation"), name, scenario, {
                    "episodes": counted["episodes"], "actions": counted["actions"],
                    "truth_actions": truth["intervals"]["actions"], "ended": counted["ended"],
                    "grasp_success": None if clean else counted["grasp_success"],
                    "truth_grasp_success": None if clean else truth["intervals"]["grasp_success"],
                    "left": None if clean else counted["left"], "product_lifted": counted["product_lifted"]}))
    return out


def markdown(rows: list) -> str:
    """The table of table_rows' rows (of any number of runs)."""
    lines = ["| Scene set | Split | Row | Scenario | Episodes | Actions by perception | Actions by truth | "
             "Grasp success, % by perception | by truth | Ended: nothing left / limit / other | "
             "Left behind | Product lifted |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for scene_set, split, row, scenario, f in rows:
        ended = " / ".join(str(f["ended"][k]) for k in ENDINGS)
        left = "(clean)" if f["left"] is None else shown(f["left"], 2)
        success = ["–" if f.get(key) is None else shown(f[key])
                   for key in ("grasp_success", "truth_grasp_success")]
        lines.append(f"| {scene_set} | {split} | {row} | {scenario} | {f['episodes']} | "
                     f"{shown(f['actions'])} | {shown(f['truth_actions'])} | {success[0]} | {success[1]} | "
                     f"{ended} | {left} | {shown(f['product_lifted'], 2)} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="+", type=pathlib.Path, help="eval_cli results.json files")
    args = parser.parse_args(argv)
    rows = []
    for path in args.results:
        rows += table_rows(json.loads(path.read_text()))
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
