"""Sixteenth session: the default palette's side of the held-out picking comparison on all 100 seeds.

The fifteenth session's held-out run (palettes 100-199 of splits.held_out_palettes(), `cell`, seeds
904 900 000 + k, k < 100) compared with the default palette on k < 20 only. The default palette was then run
on all 100 seeds (criterion in docs/experiments.md, sixteenth section):

    python -m impurity_learning.eval_cli --methods ours --rules cell --episodes 100 \\
        --palette-groups default --seed-base 904900000 --json runs/s16/default100/results.json ... \\
        --no-resume --jobs 2
    python docs/experiments_s16/default100.py extract runs/s15/heldout8b/results.json \\
        runs/s16/default100/results.json            # -> docs/experiments_s16/heldout8b_episodes.jsonl
    python docs/experiments_s16/default100.py report  # -> default100.txt

Any other held-out run and default-palette run on the same seeds (the twenty-second session's tenth set):

    python docs/experiments_s16/default100.py extract HELD.json DEFAULT.json EPISODES.jsonl
    python docs/experiments_s16/default100.py report EPISODES.jsonl

`report` reads the committed episode file: per scenario the default palette's grasp success (make eval's
measure: each episode's picked / attempts averaged, an episode without attempts at 0) on the first 20 and on
all 100 seeds, the held-out figure, the gaps, and a paired bootstrap of the 100-seed gap over the seeds; then
the same over the episodes with a grasp attempt only (thirtieth session: how much of a gap is episodes where
attention never called a TARGET).
"""
import json
import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).parent
EPISODES = HERE / "heldout8b_episodes.jsonl"
KEYS = ("scenario", "seed", "group", "palette", "targets_picked", "targets_total", "grasp_attempts",
        "grasp_success", "actions", "completed", "termination_reason")
SCENARIOS = ("random", "challenging", "invisible")


def extract(held_out_json: str, default_json: str, episodes=EPISODES) -> None:
    """Held-out episodes from the held-out run, default-palette ones from the 100-seed run (its first 20 are
    checked against the held-out run's default episodes); written to `episodes`."""
    held = json.load(open(held_out_json))["ours@cell"]["episodes"]
    default = json.load(open(default_json))["ours@cell"]["episodes"]
    earlier = {(e["scenario"], e["seed"]): e for e in held if e["group"] == "default"}
    same = sum(all(earlier[(e["scenario"], e["seed"])][k] == e[k] for k in KEYS)
               for e in default if (e["scenario"], e["seed"]) in earlier)
    print(f"default palette, the held-out run's {len(earlier)} episodes repeated: {same} alike")
    with open(episodes, "w") as f:
        for e in [e for e in held if e["group"] == "held_out"] + default:
            f.write(json.dumps({k: e[k] for k in KEYS}) + "\n")


def report(episodes=EPISODES, draws: int = 5000) -> None:
    rows = [json.loads(line) for line in open(episodes)]
    rng = np.random.default_rng(0)
    base = min(e["seed"] for e in rows)
    print(f"grasp success %, make eval's measure (`cell`, held-out palettes against the default palette, "
          f"same seeds {base} + k; {episodes})")
    print("scenario     default k<20  default k<100 (se)  held-out (n, no attempt)  gap k<20  gap k<100 "
          "[paired 95 %]  default / held-out completion %")
    for scenario in SCENARIOS:
        default = {e["seed"]: e for e in rows if e["group"] == "default" and e["scenario"] == scenario}
        held = {e["seed"]: e for e in rows if e["group"] == "held_out" and e["scenario"] == scenario}
        seeds = np.array(sorted(set(default) & set(held)))
        d = np.array([100 * default[s]["grasp_success"] for s in seeds])
        h = np.array([100 * held[s]["grasp_success"] for s in seeds])
        first = seeds - seeds.min() < 20
        samples = [rng.integers(0, len(seeds), len(seeds)) for _ in range(draws)]
        low, high = np.percentile([d[i].mean() - h[i].mean() for i in samples], [2.5, 97.5])
        none = sum(held[s]["grasp_attempts"] == 0 for s in seeds)
        completion = (100 * np.mean([default[s]["completed"] for s in seeds]),
                      100 * np.mean([held[s]["completed"] for s in seeds]))
        print(f"{scenario:12s} {d[first].mean():11.1f}  {d.mean():8.1f} ({d.std(ddof=1) / len(d) ** 0.5:.1f})"
              f"  {h.mean():12.1f} ({len(h)}, {none})  {d[first].mean() - h.mean():8.1f}  "
              f"{d.mean() - h.mean():8.1f} [{low:+.1f} .. {high:+.1f}]  "
              f"{completion[0]:.0f} / {completion[1]:.0f}")
    print("the same, only episodes with a grasp attempt (an episode without one is a perception miss: attention "
          "never called a TARGET; completion counts it)")
    print("scenario     default (n)   held-out (n)   gap")
    for scenario in SCENARIOS:
        d, h = ([100 * e["grasp_success"] for e in rows if e["group"] == group and e["scenario"] == scenario
                 and e["grasp_attempts"] > 0] for group in ("default", "held_out"))
        print(f"{scenario:12s} {np.mean(d):7.1f} ({len(d)})  {np.mean(h):7.1f} ({len(h)})  "
              f"{np.mean(d) - np.mean(h):5.1f}")


def main(argv: list) -> int:
    if argv[:1] == ["extract"] and len(argv) in (3, 4):
        extract(*argv[1:])
    elif argv[:1] == ["report"] and len(argv) in (1, 2):
        report(*argv[1:])
    else:
        print(__doc__)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
