"""Eighteenth session, tuning data only: what attention saw in the fresh-palette episodes that ended
incomplete (docs/experiments_s18/run_fresh.sh's shipped arm). Each such episode is replayed with
experiments_s17/loop_views.py's ViewCell (the same seed, palette, network and rules, so the same actions),
keeping every view with its segmentation; per view it prints attention's mode, the verifier's likeliest
region's probability (attend() with a threshold of 0.001 takes it) and whether that region lies on a target.

    python docs/experiments_s18/stalls.py docs/experiments_s18/episodes/fresh_shipped.jsonl
"""
import json
import pathlib
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "experiments_s17"))
import loop_views  # noqa: E402


def likeliest(record) -> tuple:
    """(mode of the shipped attention, the likeliest region's probability or None, on a target's cells)."""
    import dataclasses
    import re

    from impurity_attention.core.attention import AttentionMode, AttentionParams, attend
    shipped = attend(record.color, record.height, AttentionParams())
    low = attend(record.color, record.height,
                 dataclasses.replace(AttentionParams(), verifier_threshold=0.001))
    if int(low.mode) != AttentionMode.TARGET:
        return AttentionMode(int(shipped.mode)).name, None, False
    found = re.search(r"probability (\d+\.\d+)", low.reason)
    on = bool(np.any(low.target_mask & record.visible_target_cells))
    return AttentionMode(int(shipped.mode)).name, float(found.group(1)) if found else None, on


def main(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    incomplete = [r for r in rows if not r["completed"]]
    tasks = [(r["scenario"], r["seed"], r["palette"]) for r in incomplete]
    with ProcessPoolExecutor(2) as pool:
        for (scenario, seed, palette), (views, meta), row in zip(
                tasks, pool.map(loop_views.run_one, tasks), incomplete, strict=True):
            print(f"{scenario} {seed} {palette}: {row['termination']} (replay: {meta['actions']} actions, "
                  f"picked {meta['picked']}, recorded {row['actions']} / {row['picked']})")
            line = []
            for record in views:
                mode, probability, on = likeliest(record)
                shown = "v" if record.category() == "visible" else "-"
                line.append(f"{mode[0]}{shown}{'' if probability is None else f'{probability:.2f}'}"
                            f"{'*' if on else ''}")
            print("   " + " ".join(line))


if __name__ == "__main__":
    main(sys.argv[1])
