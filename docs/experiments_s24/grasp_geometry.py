"""Twenty-fourth session, tuning data only: what differs between grasps on a target that lift it and those
that lift nothing (push_out.py run ... --grasp-geometry records the nearest target's pose and contacts).

    python docs/experiments_s24/grasp_geometry.py runs/s24/geom_inv.jsonl [more.jsonl ...]
"""
import collections
import json
import sys

import numpy as np


def rows(paths):
    for path in paths:
        for line in open(path):
            episode = json.loads(line)
            for grasp in episode["grasps"]:
                if "g_shape" not in grasp or not (grasp["target"] or grasp["target_m"] < 0.03):
                    continue
                kind = "lifted it" if grasp["target"] and grasp["lifted"] else (
                    "nothing" if not grasp["lifted"] else "other body")
                yield kind, grasp, episode


def main(paths) -> None:
    groups = collections.defaultdict(list)
    for kind, grasp, _ in rows(paths):
        groups[kind].append(grasp)
    for kind, grasps in groups.items():
        print(f"== grasps near a target that {kind}: {len(grasps)}")
        shapes = collections.Counter(g["g_shape"] for g in grasps)
        print("   shapes:", dict(sorted(shapes.items())))
        for key, bins in (("g_tilt", (0, 5, 15, 30, 90)), ("g_closing", (0, 15, 30, 45, 60, 75, 90.1)),
                          ("g_base", (-1, 0.003, 0.01, 0.02, 1)), ("g_touching", (0, 1, 2, 3, 10)),
                          ("object_m", (0, 0.03, 0.04, 0.05, 0.07, 1))):
            values = np.array([g[key] for g in grasps], float)
            counts, _ = np.histogram(values, bins)
            cells = " ".join(f"[{lo:g},{hi:g}):{c}"
                             for lo, hi, c in zip(bins[:-1], bins[1:], counts, strict=True))
            print(f"   {key:10s} median {np.median(values):7.3f} | {cells}")
        over = [g["g_over"] for g in grasps if g["g_over"] is not None]
        print(f"   touching product higher than the target's top: {sum(o > 0 for o in over)} of "
              f"{len(grasps)}")
    print("== success by shape (lifted it / near-target grasps)")
    by_shape = collections.defaultdict(lambda: [0, 0])
    for kind, grasp, _ in rows(paths):
        by_shape[grasp["g_shape"]][0] += kind == "lifted it"
        by_shape[grasp["g_shape"]][1] += 1
    for shape, (ok, n) in sorted(by_shape.items()):
        print(f"   {shape:14s} {ok}/{n} ({100 * ok / n:.0f} %)")
    print("== success by closing angle to the block's x axis, non-round shapes")
    for lo, hi in ((0, 20), (20, 45), (45, 70), (70, 90.1)):
        sel = [k == "lifted it" for k, g, _ in rows(paths) if g["g_shape"] not in ("cylinder",)
               and lo <= g["g_closing"] < hi]
        print(f"   [{lo},{hi}) {sum(sel)}/{len(sel)}")


if __name__ == "__main__":
    main(sys.argv[1:])
