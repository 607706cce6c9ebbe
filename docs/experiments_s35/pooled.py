"""Thirty-fifth session: the criterion's pooled figures of two picking arms over their scenarios (mark 5):
grasp success (picks / attempts over every episode), completion and actions per episode, each arm's files
read as push_out.py writes them, and the paired bootstrap of the pooled grasp success change over seeds.

    python docs/experiments_s35/pooled.py runs/s34/picking_shipped runs/s34/picking_net
"""
import json
import pathlib
import sys

import numpy as np

SCENARIOS = ("invisible", "challenging", "random")


def episodes(arm: pathlib.Path) -> dict:
    rows = {}
    for scenario in SCENARIOS:
        for line in (arm / f"{scenario}.jsonl").read_text().splitlines():
            row = json.loads(line)
            rows[(scenario, row["seed"])] = row
    return rows


def figures(rows: list) -> tuple:
    picks, attempts = sum(r["picked"] for r in rows), sum(r["attempts"] for r in rows)
    return (100 * picks / attempts, 100 * np.mean([r["completed"] for r in rows]),
            float(np.mean([r["actions"] for r in rows])))


def main() -> None:
    base, other = (episodes(pathlib.Path(a)) for a in sys.argv[1:3])
    keys = sorted(set(base) & set(other))
    b, o = [base[k] for k in keys], [other[k] for k in keys]
    fb, fo = figures(b), figures(o)
    print(f"{len(keys)} seeds in both arms ({sys.argv[1]} -> {sys.argv[2]})")
    for name, x, y, unit in (("grasp success, pooled", fb[0], fo[0], " %"), ("completion", fb[1], fo[1], " %"),
                             ("actions per episode", fb[2], fo[2], "")):
        print(f"  {name}: {x:.2f}{unit} -> {y:.2f}{unit} ({y - x:+.2f}{' points' if unit else ''}"
              f"{'' if unit else f', {100 * (y / x - 1):+.1f} %'})")
    rng = np.random.default_rng(0)
    bp, ba = np.array([r["picked"] for r in b]), np.array([r["attempts"] for r in b])
    op, oa = np.array([r["picked"] for r in o]), np.array([r["attempts"] for r in o])
    draws = []
    for _ in range(5000):
        i = rng.integers(0, len(keys), len(keys))
        draws.append(100 * (op[i].sum() / oa[i].sum() - bp[i].sum() / ba[i].sum()))
    low, high = np.percentile(draws, [2.5, 97.5])
    print(f"  pooled grasp success change, paired bootstrap over seeds 95 %: {low:+.2f} to {high:+.2f} points "
          "(5000 draws)")


if __name__ == "__main__":
    main()
