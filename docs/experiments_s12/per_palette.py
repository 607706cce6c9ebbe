"""Per row, group and scenario the unrounded figures of a held-out run (scripts/run_heldout.sh's
results.json), and the held-out palettes with incomplete episodes and why they ended.

    python docs/experiments_s12/per_palette.py runs/s12/heldout7/results.json ours@cell
"""
import collections
import json
import sys


def main() -> None:
    results = json.load(open(sys.argv[1]))
    row = sys.argv[2] if len(sys.argv) > 2 else "ours@cell"
    for group, scenarios in results[row]["groups"].items():
        for scenario, figures in scenarios.items():
            print(f"{row} {group:8s} {scenario:11s} n {figures['episodes']:3d} grasp success "
                  f"{figures['grasp_success']:.3f} completion {figures['completion']:.2f}")
    incomplete = collections.defaultdict(list)
    episodes = collections.Counter()
    for episode in results[row]["episodes"]:
        if episode["group"] != "held_out":
            continue
        episodes[episode["palette"]] += 1
        if not episode["completed"]:
            incomplete[episode["palette"]].append(episode["termination_reason"])
    print("held-out palettes with incomplete episodes (incomplete / episodes, termination reasons):")
    for palette, reasons in sorted(incomplete.items(), key=lambda item: (-len(item[1]), item[0])):
        print(f"  {palette:18s} {len(reasons)}/{episodes[palette]}  {dict(collections.Counter(reasons))}")
    others = sum(count for palette, count in episodes.items() if palette not in incomplete)
    print(f"  the others: {others} episodes, all complete")


if __name__ == "__main__":
    main()
