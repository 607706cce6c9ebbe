"""Sixteenth session, tuning palettes only: would a stricter verifier threshold while a heap is left trade
false TARGETs on hidden-impurity views for visible impurities found?

For every scene of calibrate_attention's tuning palettes on their own layouts (collect_palettes("tuning",
own_layouts=True): visible, clean and invisible-scenario scenes): the verifier's likeliest region's
probability, whether a TARGET there lands on an impurity (visible scenes), and whether a heap that could hide
a target is left (select_occluded_region). `report` counts, for thresholds t applied only when a heap is left,
the visible impurities still found and the TARGETs left on clean and invisible scenes (where any TARGET is on
product).

    python docs/experiments_s16/heap_probe.py collect > runs/s16/heap_probe.jsonl
    python docs/experiments_s16/heap_probe.py report runs/s16/heap_probe.jsonl
"""
import dataclasses
import json
import sys

sys.path.insert(0, "scripts")
import calibrate_attention as ca  # noqa: E402

from impurity_attention.core import evaluation  # noqa: E402
from impurity_attention.core.attention import AttentionParams, attend  # noqa: E402
from impurity_attention.core.density import find_clusters, select_occluded_region  # noqa: E402
from impurity_attention.core.verifier import default_verifier  # noqa: E402
from impurity_common.grid import HeightmapGrid  # noqa: E402

ANY = dataclasses.replace(AttentionParams(), verifier_threshold=1e-9, verifier_last_look=0.0)
THRESHOLDS = (0.0, 0.75, 0.8, 0.85, 0.9, 0.95, 0.99)


def row(record) -> dict | None:
    category = record.category()
    if category is None:
        return None
    output = attend(record.color, record.height, ANY)
    verdict = evaluation.judge(record, output) if category == "visible" else None
    probability = float(output.reason.split("probability ")[1].split(" ")[0]) if "probability" in \
        output.reason else (1.0 if output.mode.name == "TARGET" else 0.0)
    heap = select_occluded_region(find_clusters(record.height, HeightmapGrid().resolution, ANY.density))
    return {"palette": record.palette, "scenario": record.scenario, "seed": record.seed, "category": category,
            "p": probability, "mode": output.mode.name,
            "on_impurity": bool(verdict.success) if verdict is not None else None, "heap": heap is not None}


def report(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    least = default_verifier().threshold
    print(f"{len(rows)} scenes; the shipped threshold {least:.2f}; a threshold t applies only with a heap "
          "left")
    for category in ("visible", "no_impurity", "invisible"):
        part = [r for r in rows if r["category"] == category]
        print(f"{category}: {len(part)} scenes, {sum(r['heap'] for r in part)} with a heap left")
    print("t      visible found (of which with a heap)   TARGET on clean scenes   TARGET on invisible scenes")
    for t in THRESHOLDS:
        def target(r, t=t):
            return r["p"] >= max(least, t if r["heap"] else 0.0)
        visible = [r for r in rows if r["category"] == "visible"]
        found = sum(target(r) and r["on_impurity"] for r in visible)
        found_heap = sum(target(r) and r["on_impurity"] for r in visible if r["heap"])
        clean = sum(target(r) for r in rows if r["category"] == "no_impurity")
        hidden = sum(target(r) for r in rows if r["category"] == "invisible")
        print(f"{t:4.2f}   {found:5d} ({found_heap:5d})                       {clean:5d}                    "
              f"{hidden:5d}")


def main() -> None:
    if sys.argv[1] == "collect":
        for scene in ca.collect_palettes("tuning", own_layouts=True):
            entry = row(scene)
            if entry is not None:
                print(json.dumps(entry), flush=True)
    else:
        report(sys.argv[2])


if __name__ == "__main__":
    main()
