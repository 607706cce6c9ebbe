"""One table across scene sets: eval_cli runs with --scene-set (each its results.json), the same episodes
counted by perception (as a real cell counts) and by the simulator's truth, per set, scenario and row.

    python -m impurity_learning.scene_set_table runs/eval/*-tuning/results.json

Per row: episodes; actions per scene by perception and by truth (means with 95 % t intervals); how the
perception-counted episodes ended (the cell's own "nothing left" / the action limit / otherwise); impurities
left behind and product lifted per scene, by the truth recorded beside. A set without impurities (clean)
is read from its clean scenes.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

from .perception_figures import ENDINGS, shown


def table_rows(results: dict) -> list:
    """[(scene set, split, row, scenario, figures)] of one eval_cli results.json; figures: episodes, actions
    by perception and by truth (mean_interval dicts), ended ({ENDINGS: episodes}), left and product_lifted
    (mean_interval dicts; left None on clean scenes)."""
    meta = results["_meta"]
    out = []
    for row in meta["rows"]:
        entry = results[row]
        if entry.get("missing") or "by_perception" not in entry:
            continue
        for scenario in meta["scenarios"]:
            counted = entry["by_perception"]["scenarios"][scenario]
            clean = not counted["episodes"]
            if clean:
                counted = entry["by_perception"]["clean_scenes"][scenario]
            if not counted["episodes"]:
                continue
            truth = entry["scenarios"][scenario]
            out.append((meta.get("scene_set", "paper"), meta.get("split", "evaluation"), row, scenario, {
                "episodes": counted["episodes"], "actions": counted["actions"],
                "truth_actions": truth["intervals"]["actions"], "ended": counted["ended"],
                "left": None if clean else counted["left"], "product_lifted": counted["product_lifted"]}))
    return out


def markdown(rows: list) -> str:
    """The table of table_rows' rows (of any number of runs)."""
    lines = ["| Scene set | Split | Row | Scenario | Episodes | Actions by perception | Actions by truth | "
             "Ended: nothing left / limit / other | Left behind | Product lifted |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for scene_set, split, row, scenario, f in rows:
        ended = " / ".join(str(f["ended"][k]) for k in ENDINGS)
        left = "(clean)" if f["left"] is None else shown(f["left"], 2)
        lines.append(f"| {scene_set} | {split} | {row} | {scenario} | {f['episodes']} | "
                     f"{shown(f['actions'])} | {shown(f['truth_actions'])} | {ended} | {left} | "
                     f"{shown(f['product_lifted'], 2)} |")
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
