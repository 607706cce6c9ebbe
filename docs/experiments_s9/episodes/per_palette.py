"""Ninth session: per palette and scenario, completed / episodes of a run's held-out group (results.json),
and the unrounded grasp success per group and scenario.

    python docs/experiments_s9/episodes/per_palette.py runs/s9/heldout4/results.json [ours@cell]
"""
import collections
import json
import sys

import numpy as np

row = sys.argv[2] if len(sys.argv) > 2 else "ours@cell"
episodes = json.load(open(sys.argv[1]))[row]["episodes"]
for group in ("default", "held_out"):
    for scenario in ("random", "challenging", "invisible"):
        chosen = [e for e in episodes if e["group"] == group and e["scenario"] == scenario]
        print(f"{row} {group:8s} {scenario:11s} n {len(chosen):3d} grasp success "
              f"{100 * np.mean([e['grasp_success'] for e in chosen]):.3f} completion "
              f"{100 * np.mean([e['completed'] for e in chosen]):.2f}")
incomplete = collections.Counter()
total = collections.Counter()
for e in episodes:
    if e["group"] == "held_out":
        total[e["palette"]] += 1
        incomplete[e["palette"]] += not e["completed"]
print("held-out palettes with incomplete episodes (incomplete / episodes, termination reasons):")
for palette, count in incomplete.most_common():
    if count:
        reasons = collections.Counter(e["termination_reason"] for e in episodes
                                      if e["palette"] == palette and not e["completed"])
        print(f"  {palette:18s} {count}/{total[palette]}  {dict(reasons)}")
print(f"  the others: {sum(total.values()) - sum(total[p] for p in incomplete if incomplete[p])} episodes, "
      "all complete")
