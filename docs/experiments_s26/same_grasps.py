"""Twenty-sixth session: do two push_out.py runs on the same seeds make the same grasps?

    python docs/experiments_s26/same_grasps.py CANDIDATE.jsonl ADOPTED.jsonl

For each seed in both files: alike when the grasp records (step, mode, where and what was lifted) and the
episode's end (termination, picked, attempts, actions) are equal; else the first grasp that differs is
printed. Used for the known product's equivalence check (docs/experiments.md, twenty-sixth section).
"""
import json
import sys

ENDS = ("termination", "picked", "attempts", "actions")


def main(candidate: str, adopted: str) -> None:
    runs = [{r["seed"]: r for r in map(json.loads, open(path))} for path in (candidate, adopted)]
    seeds = sorted(set(runs[0]) & set(runs[1]))
    differing = []
    for seed in seeds:
        a, b = runs[0][seed], runs[1][seed]
        if a["grasps"] == b["grasps"] and all(a[k] == b[k] for k in ENDS):
            continue
        differing.append(seed)
        first = next((i for i, (x, y) in enumerate(zip(a["grasps"], b["grasps"], strict=False)) if x != y),
                     min(len(a["grasps"]), len(b["grasps"])))
        print(f"seed {seed} ({a['palette']}): ends {[a[k] for k in ENDS]} -> {[b[k] for k in ENDS]}; "
              f"grasp records differ from grasp {first + 1} (candidate {len(a['grasps'])}, adopted "
              f"{len(b['grasps'])})")
        for name, run in (("candidate", a), ("adopted", b)):
            if first < len(run["grasps"]):
                print(f"  {name}: {json.dumps(run['grasps'][first])[:300]}")
    print(f"{len(seeds) - len(differing)} of {len(seeds)} episodes alike")


if __name__ == "__main__":
    main(*sys.argv[1:3])
