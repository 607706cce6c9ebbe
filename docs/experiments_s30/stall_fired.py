"""Thirtieth session: how often the stall look fired in `run_stall25.sh stall`'s episodes and on what.

    python docs/experiments_s30/stall_fired.py docs/experiments_s30/episodes/stall25_shipped_challenging.jsonl \
        docs/experiments_s30/episodes/stall25_stall_challenging.jsonl

For one scenario's two episode files (shipped arm, stall arm): the stall arm's grasps decided on a stall look's TARGET (`stall` in push_out.py's grasp records),
how many lifted a target, how many lifted product and how many lifted nothing; and the episodes whose picks,
attempts, actions or ending differ between the arms (same seeds), with both arms' figures.
"""
import json
import pathlib
import sys



def episodes(path: str) -> dict:
    return {e["seed"]: e for e in map(json.loads, pathlib.Path(path).read_text().splitlines())}


def main(shipped_file: str, stall_file: str) -> int:
    base, stall = episodes(shipped_file), episodes(stall_file)
    for scenario in sorted({e["scenario"] for e in stall.values()}):
        fired = [g for e in stall.values() if e["scenario"] == scenario for g in e["grasps"] if g.get("stall")]
        target = sum(g["lifted"] and g["target"] for g in fired)
        product = sum(g["lifted"] and not g["target"] for g in fired)
        print(f"{scenario}: {sum(e['scenario'] == scenario for e in stall.values())} episodes; grasps on a stall look's TARGET {len(fired)} in "
              f"{sum(any(g.get('stall') for g in e['grasps']) for e in stall.values() if e['scenario'] == scenario)} episodes: lifted a "
              f"target {target}, lifted product {product}, lifted nothing {len(fired) - target - product}")
        keys = ("picked", "attempts", "actions", "termination")
        for seed in sorted(s for s in set(base) & set(stall) if stall[s]["scenario"] == scenario):
            a, b = base[seed], stall[seed]
            if any(a[k] != b[k] for k in keys):
                print(f"   {seed} {a['palette']:16s} shipped {a['picked']}/{a['total']} picked, {a['attempts']} "
                      f"attempts, {a['actions']} actions, {a['termination']}  |  stall {b['picked']}/{b['total']}, "
                      f"{b['attempts']}, {b['actions']}, {b['termination']}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(*sys.argv[1:]))
