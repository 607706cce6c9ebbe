"""Per held-out palette lines of an eval_cli results.json (grasp successes / attempts, completed episodes,
why the others ended), as in docs/heldout3/picking*.md.

    python docs/experiments_s8/per_palette.py runs/s8_heldout3/results.json
"""
import collections, json, sys

data = json.load(open(sys.argv[1]))
print("| palette | rules | grasps | completed | other ends |")
print("|---|---|---|---|---|")
for row in ("ours@cell", "ours@none"):
    episodes = data[row]["episodes"]
    if isinstance(episodes, dict):
        episodes = [e for group in episodes.values() for e in group]
    by = collections.defaultdict(list)
    for e in episodes:
        if e["group"] == "held_out":
            by[e["palette"]].append(e)
    for palette in data["_generalisation"]["palettes"]["held_out"]:
        es = by[palette]
        ends = collections.Counter(e["termination_reason"] for e in es if not e["completed"])
        print(f"| {palette} | {row.split('@')[1]} | {sum(e['grasp_successes'] for e in es)}/"
              f"{sum(e['grasp_attempts'] for e in es)} | {sum(e['completed'] for e in es)}/{len(es)} | "
              f"{', '.join(f'{k} {v}' for k, v in ends.items()) or '-'} |")
