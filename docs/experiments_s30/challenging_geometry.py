"""Thirtieth session, tuning data only: the shipped cell's grasps in challenging scenes by the nearest target's
shape (push_out.py --grasp-geometry records), and on half cylinders by the closing axis's angle to the
cylinder's axis.

    python docs/experiments_s30/challenging_geometry.py docs/experiments_s30/episodes/stall25_shipped_challenging.jsonl

g_closing is the angle between the gripper's closing axis and the block's x axis, folded to [0, 90] degrees; a
half cylinder's x axis is its length (shapes.random_dims: (length, diameter, radius)), so 0 closes on its flat
end faces and 90 across its curved side. "Tilted": more than 20 degrees between the block's z axis and the
vertical. A grasp failed when it did not lift a target.
"""
import collections
import json
import sys


def main(path: str) -> int:
    grasps = [g for line in open(path) for g in json.loads(line)["grasps"] if "g_shape" in g]
    failed = [g for g in grasps if not (g["lifted"] and g["target"])]
    print(f"{path}: {len(grasps)} grasps with geometry, {len(failed)} failed "
          f"({sum(g['lifted'] and not g['target'] for g in failed)} lifted product, "
          f"{sum(not g['lifted'] and g['target_m'] < 0.02 for g in failed)} lifted nothing within 2 cm of a target)")
    total, bad = collections.Counter(), collections.Counter()
    for g in grasps:
        key = (g["g_shape"], "tilted" if g["g_tilt"] > 20 else "upright")
        total[key] += 1
        bad[key] += not (g["lifted"] and g["target"])
    print("nearest target's shape: failed / grasps")
    for key in sorted(total):
        print(f"   {key[0]:14s} {key[1]:8s} {bad[key]:3d} / {total[key]}")
    bins = collections.defaultdict(lambda: [0, 0])
    for g in grasps:
        if g["g_shape"] == "half_cylinder" and g["g_tilt"] <= 20:
            row = bins[min(int(g["g_closing"] // 15) * 15, 75)]
            row[0] += bool(g["lifted"] and g["target"])
            row[1] += 1
    print("half cylinders lying flat, closing axis to the cylinder's axis: lifted / grasps")
    for start in sorted(bins):
        print(f"   [{start:2d}, {start + 15:2d}) deg  {bins[start][0]:3d} / {bins[start][1]}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
