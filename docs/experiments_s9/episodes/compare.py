"""Ninth session: the adoption criterion's figures from two runs of run_truth_counted.sh (results.json, or results.partial.jsonl while running):
grasp success (the mean of the episodes' own, as eval_cli.aggregate) and completion per group and scenario, and the tuning group's means over
the three scenarios; then the episodes that differ.

    python docs/experiments_s9/episodes/compare.py runs/s9/episodes_v1 runs/s9/episodes_v2
"""
import json
import pathlib
import sys

SCENARIOS = ("random", "challenging", "invisible")


def load(directory):
    """Episodes of a finished run (results.json) or of one still running (results.partial.jsonl)."""
    if pathlib.Path(f"{directory}/results.json").exists():
        rows = json.load(open(f"{directory}/results.json"))["ours@cell"]["episodes"]
    else:
        rows = [json.loads(line)["record"] for line in open(f"{directory}/results.partial.jsonl")]
    return {(r["group"], r["scenario"], r["seed"]): r for r in rows}


def figures(rows, group):
    out = {}
    for scenario in SCENARIOS:
        chosen = [r for (g, s, _), r in rows.items() if g == group and s == scenario]
        out[scenario] = (100 * sum(r["grasp_success"] for r in chosen) / max(len(chosen), 1),
                         100 * sum(r["completed"] for r in chosen) / max(len(chosen), 1), len(chosen))
    return out


runs = [load(d) for d in sys.argv[1:3]]
for group in ("default", "tuning"):
    for name, rows in zip(sys.argv[1:3], runs):
        f = figures(rows, group)
        grasp = " / ".join(f"{f[s][0]:.1f}" for s in SCENARIOS)
        done = " / ".join(f"{f[s][1]:.1f}" for s in SCENARIOS)
        mean_g = sum(f[s][0] for s in SCENARIOS) / 3
        mean_c = sum(f[s][1] for s in SCENARIOS) / 3
        print(f"{group:8s} {name:28s} episodes {sum(f[s][2] for s in SCENARIOS):3d}  grasp success {grasp} "
              f"(mean {mean_g:.1f})  completion {done} (mean {mean_c:.1f})")
keys = sorted(set(runs[0]) & set(runs[1]))
fields = ("targets_picked", "grasp_attempts", "grasp_successes", "completed")
differ = [k for k in keys if any(runs[0][k][f] != runs[1][k][f] for f in fields)]
print(f"{len(differ)} of {len(keys)} episode pairs differ in {', '.join(fields)}")
for k in differ:
    a, b = runs[0][k], runs[1][k]
    print(f"  {k[0]:8s} {k[1]:11s} {k[2]:6d} {a['palette'] or 'blocks':16s} "
          + "  ".join(f"{f} {a[f]}->{b[f]}" for f in fields if a[f] != b[f])
          + f"  ({a['termination_reason']} -> {b['termination_reason']})")
