"""Eighteenth session: which of `make eval`'s episodes changed between two runs (docs/results.json before and
after), per row: episodes matched by scenario, palette group, palette and seed, compared in targets picked,
grasp attempts, actions and ending; and each row's default-palette grasp success and completion per scenario.

    git show <commit>:docs/results.json > runs/s18/results_before.json
    python docs/experiments_s18/eval_diff.py runs/s18/results_before.json docs/results.json
"""
import json
import sys
from collections import defaultdict

FIELDS = ("targets_picked", "grasp_attempts", "actions", "termination_reason")


def episodes(path: str) -> dict:
    rows = json.load(open(path))
    return {row: {(e["scenario"], e["group"], e["palette"], e["seed"]): e for e in value["episodes"]}
            for row, value in rows.items() if not row.startswith("_")}  # _meta, _generalisation


def default_rates(by_key: dict) -> str:
    parts = []
    for scenario in ("random", "challenging", "invisible"):
        chosen = [e for (s, group, _, _), e in by_key.items() if s == scenario and group == "default"]
        if chosen:
            success = 100 * sum(e["grasp_success"] for e in chosen) / len(chosen)
            done = 100 * sum(e["completed"] for e in chosen) / len(chosen)
            parts.append(f"{scenario} {success:.1f} / {done:.0f}")
    return ", ".join(parts)


def main(before_path: str, after_path: str) -> None:
    before, after = episodes(before_path), episodes(after_path)
    for row in after:
        old, new = before.get(row, {}), after[row]
        shared = set(old) & set(new)
        changed = defaultdict(int)
        for key in shared:
            if any(old[key][f] != new[key][f] for f in FIELDS):
                changed[(key[0], key[1])] += 1
        print(f"{row}: {len(shared)} episodes in both runs, {sum(changed.values())} changed "
              f"({', '.join(f'{s}/{g} {n}' for (s, g), n in sorted(changed.items())) or 'none'}); "
              f"{len(new) - len(shared)} only in the new run")
        print(f"  default palette, grasp success / completion %: before {default_rates(old)}; "
              f"after {default_rates(new)}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
