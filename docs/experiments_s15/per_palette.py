"""Incomplete held-out picking episodes per palette, from a run_heldout.sh results.json (its one Ours row:
ours@cell, or ours@none for a RULES=none run).

    python docs/experiments_s15/per_palette.py runs/s15/heldout8b/results.json \
        > docs/heldout8b/per_palette_cell.txt
"""
import collections
import json
import sys

d = json.load(open(sys.argv[1]))
row = next(r for r in ("ours@cell", "ours@none") if r in d)
print(f"$ python docs/experiments_s15/per_palette.py {sys.argv[1]}")
for g in ("default", "held_out"):
    for s, m in d[row]["groups"][g].items():
        print(f"{row} {g:8s} {s:11s} n {m['episodes']:3d} grasp success {m['grasp_success']:.3f} "
              f"completion {m['completion']:.2f}")
inc, n, why = collections.Counter(), collections.Counter(), collections.defaultdict(collections.Counter)
for e in d[row]["episodes"]:
    if e["group"] != "held_out":
        continue
    n[e["palette"]] += 1
    if not e["completed"]:
        inc[e["palette"]] += 1
        why[e["palette"]][e["termination_reason"]] += 1
print("held-out palettes with incomplete episodes (incomplete / episodes, termination reasons):")
for p, k in sorted(inc.items(), key=lambda x: (-x[1], x[0])):
    print(f"  {p:18s} {k}/{n[p]}  {dict(why[p])}")
print(f"  the others: {sum(n[p] for p in n if p not in inc)} episodes, all complete")
