"""Twenty-third session, tuning data only: attention's target mask against the truth at every grasp, by what
the grasp did. Reads push_out.py runs made with --mask-truth (the episodes of seeds 6 500-6 699 that had a
failed grasp in either palette's shipped arm, rerun with the mask recorded; they reproduce the shipped arms'
actions and attempts exactly).

    python docs/experiments_s14/push_out.py run invisible 0 runs/s23/mask_tuning.jsonl --seed-base 6100 \\
        --only K ... --mask-truth                       # and the same with --palette blocks
    python docs/experiments_s23/mask_truth.py runs/s23/mask_tuning.jsonl runs/s23/mask_default.jsonl
"""
import json
import sys

import numpy as np


def kind(grasp: dict) -> str:
    if grasp["target"]:
        return "lifted a target"
    if grasp["lifted"]:
        return "lifted product"
    return "nothing, near a target" if grasp["target_m"] < grasp["object_m"] else "nothing, near product"


def main() -> None:
    for path in sys.argv[1:]:
        rows = [json.loads(line) for line in open(path)]
        groups = {}
        for row in rows:
            for grasp in row["grasps"]:
                if "mask_precision" in grasp:
                    groups.setdefault(kind(grasp), []).append(grasp)
        print(f"{path}: {len(rows)} episodes")
        print("  grasp                    n   mask on target: median  <0.9  <0.5   cells median  bodies>1   "
              "m_t on target <0.9")
        for name in ("lifted a target", "nothing, near a target", "lifted product", "nothing, near product"):
            part = groups.get(name, [])
            if not part:
                continue
            precision = np.array([g["mask_precision"] for g in part])
            region = np.array([g["region_precision"] for g in part])
            print(f"  {name:22s} {len(part):4d}   {np.median(precision):22.2f} {np.sum(precision < 0.9):5d} "
                  f"{np.sum(precision < 0.5):5d} {np.median([g['mask_cells'] for g in part]):14.0f} "
                  f"{sum(g['mask_bodies'] > 1 for g in part):9d} {np.sum(region < 0.9):19d}")


if __name__ == "__main__":
    main()
