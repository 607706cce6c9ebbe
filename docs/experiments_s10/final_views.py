"""Tenth session, tuning data only: how do truth-counted episodes end, and what does attention see in the
last view? Runs Ours (`cell` rules, shipped attention) on tuning palettes with tuning seeds (71000 + k),
one episode per palette and scenario, and keeps each episode's last view as a SceneRecord (the remaining
targets labelled):
- an episode that ended "no_target_or_cluster_left" with a target still in the workspace: what the
  verifier and the clusters made of the view that ended it;
- an episode that picked every target: the view after its last grasp, with no impurity left, which is
  what a real cell looks at before it calls the scene clean (a last look must stay quiet there).

    python docs/experiments_s10/final_views.py collect --shard 0/2   # and 1/2, in parallel
    python docs/experiments_s10/final_views.py report

Palettes: the 96 fresh tuning random palettes (random-96 ... 191, never fitted on) and the four named tuning
palettes. Records in runs/s10/final_views_<shard>.npz, summaries in runs/s10/final_views_<shard>.jsonl.
"""
import argparse
import json
import pathlib
import sys

import numpy as np

from impurity_attention.core import evaluation
from impurity_attention.core.heightmap import rgbd_to_heightmaps
from impurity_common.grid import HeightmapGrid
from impurity_learning import splits

OUT = pathlib.Path("runs/s10")
PALETTES = list(splits.TUNING_NAMED) + [f"random-{s}" for s in range(96, 192)]
SCENARIOS = ("random", "challenging", "invisible")
SEED_BASE = 71000


def record_now(world, scenario, seed, palette, grid=HeightmapGrid()):
    """The world as it is now, as a SceneRecord (targets: those still in the scene)."""
    frame = world.render()
    truth = world.ground_truth(frame)
    maps = rgbd_to_heightmaps(frame.color, frame.depth, frame.intrinsics, frame.camera_pose, grid,
                              labels=frame.segmentation)
    ids = tuple(int(b) for b in truth.target_ids if b in truth.poses)
    cells = tuple(grid.base_to_pixel(*truth.poses[b][0][:2]) for b in ids)
    return evaluation.SceneRecord(scenario, int(seed), len(ids), -1, maps.color, maps.height, maps.labels,
                                  ids, cells, palette)


def collect(shard: str):
    from tqdm import tqdm

    from impurity_learning.agents import make_agent
    from impurity_learning.evaluate import SimCell
    from impurity_policy.core import picking
    from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
    from impurity_policy.core.episode import EpisodeRequest
    from ur5_driver_sim.core.world import CellWorld

    index, count = (int(x) for x in shard.split("/"))
    OUT.mkdir(parents=True, exist_ok=True)
    world = CellWorld(mode="floating")
    agent = make_agent("ours", SHIPPED_CHECKPOINT, "cell")
    tasks = [(p, s, SEED_BASE + 10 * n + k) for n, p in enumerate(PALETTES) for k, s in enumerate(SCENARIOS)]
    tasks = tasks[index::count]
    records, summaries = [], []
    for palette, scenario, seed in tqdm(tasks, desc=f"episodes {shard}"):
        cell = SimCell(world, agent)
        summary = picking.run_episode(cell, EpisodeRequest(scenario, seed=seed, palette=palette),
                                      f"{scenario}-{seed}", on_error=lambda e: (_ for _ in ()).throw(e))
        record = record_now(world, scenario, seed, palette)
        att = cell._sensed.attention
        summaries.append({"palette": palette, "scenario": scenario, "seed": seed,
                          "termination": summary["termination_reason"], "completed": summary["completed"],
                          "picked": summary["targets_picked"], "total": summary["targets_total"],
                          "left": int(cell._sensed.truth.targets_remaining),
                          "outside": int(cell._sensed.truth.targets_out_of_workspace), "actions": summary["actions"],
                          "mode": att.mode.name, "reason": att.reason, "record": len(records)})
        records.append(record)
    evaluation.save_records(OUT / f"final_views_{index}.npz", records)
    (OUT / f"final_views_{index}.jsonl").write_text("".join(json.dumps(s) + "\n" for s in summaries))


def load():
    rows, records = [], []
    for path in sorted(OUT.glob("final_views_*.jsonl")):
        shard_records = evaluation.load_records(path.with_suffix(".npz"))
        for line in path.read_text().splitlines():
            row = json.loads(line)
            rows.append(row)
            records.append(shard_records[row["record"]])
    return rows, records


def report():
    from collections import Counter
    rows, _ = load()
    print(f"{len(rows)} episodes on {len({r['palette'] for r in rows})} tuning palettes (seeds {SEED_BASE}+)")
    for scenario in SCENARIOS:
        sub = [r for r in rows if r["scenario"] == scenario]
        ends = Counter(r["termination"] for r in sub)
        done = sum(r["completed"] for r in sub)
        print(f"  {scenario:12s} completed {done}/{len(sub)}  ends: {dict(ends)}")
    left = [r for r in rows if r["termination"] == "no_target_or_cluster_left" and r["left"] > 0]
    print(f"ended by attention with a target left: {len(left)}")
    for r in left:
        print(f"  {r['palette']:16s} {r['scenario']:12s} {r['seed']}  picked {r['picked']}/{r['total']} "
              f"| {r['reason'][:140]}")


def scored(record, params=None):
    """attend() on a record, and the verifier's probability of each candidate with whether it lies on a
    remaining target: (output, [(probability, on_target)], chosen cluster or None, visible target cells)."""
    from impurity_attention.core.attention import AttentionParams, attend, salient_regions, sanitize, scene_maps
    from impurity_attention.core.density import find_clusters, select_occluded_region
    from impurity_attention.core.verifier import candidate_features, default_verifier

    params = params or AttentionParams()
    output = attend(record.color, record.height, params)
    color, height = sanitize(record.color, record.height)
    objects = height > params.density.occupied_height
    _, conspicuity = scene_maps(color, objects, params)
    regions = salient_regions(_, objects, params)
    targets = record.visible_target_cells
    scores = []
    if regions:
        candidates, features = zip(*candidate_features(color, height, objects, conspicuity, regions), strict=True)
        if features[0] is not None:
            prob = default_verifier().probability(np.array(features))
            scores = [(float(p), bool(np.any(c.mask & targets))) for p, c in zip(prob, candidates, strict=True)]
    chosen = select_occluded_region(find_clusters(height, HeightmapGrid().resolution, params.density))
    return output, scores, chosen, int(np.count_nonzero(targets))


def analyse():
    """What the last views show, and how a last look at the verifier's probability would act there."""
    from collections import Counter
    rows, records = load()
    left, clean = [], []
    for row, record in zip(rows, records, strict=True):
        if row["termination"] == "no_target_or_cluster_left" and row["left"] > 0:
            left.append((row, record))
        elif row["completed"]:
            clean.append((row, record))
    print(f"last views with a target left (ended by attention): {len(left)}")
    kinds = Counter()
    left_best = []
    for row, record in left:
        output, scores, chosen, visible = scored(record)
        best = max(scores, default=(0.0, False))
        on = [p for p, hit in scores if hit]
        kind = ("hidden" if visible < evaluation.MIN_VISIBLE_CELLS else
                "visible, not a candidate" if not on else
                "visible, likeliest candidate" if best[1] else "visible, not the likeliest")
        kinds[kind] += 1
        left_best.append(best[0] if best[1] else 0.0)
        print(f"  {row['palette']:16s} {row['scenario']:12s} {row['seed']}  {kind:28s} visible {visible:4d} "
              f"target p {max(on, default=float('nan')):.2f} best p {best[0]:.2f} | {output.reason[:90]}")
    print("  " + ", ".join(f"{k}: {v}" for k, v in kinds.items()))
    quiet = []
    for _row, record in clean:
        output, scores, chosen, _ = scored(record)
        if chosen is None and output.mode.name != "TARGET":
            quiet.append(max((p for p, _ in scores), default=0.0))
        elif output.mode.name == "TARGET":
            quiet.append(float("inf"))  # already a false TARGET, with or without a last look
    quiet = np.array(quiet)
    print(f"clean last views (every target picked) with neither TARGET nor a heap: "
          f"{np.count_nonzero(np.isfinite(quiet))}; already TARGET: {np.count_nonzero(~np.isfinite(quiet))} "
          f"of {len(clean)}")
    print("last look at probability >= t: rescued (target the likeliest, p >= t) / clean last views grasped")
    for t in np.arange(0.05, 0.69, 0.05):
        rescued = sum(p >= t for p in left_best)
        grasped = int(np.count_nonzero(np.isfinite(quiet) & (quiet >= t)))
        print(f"  t {t:.2f}: rescued {rescued}/{len(left)}, clean grasped {grasped}/"
              f"{np.count_nonzero(np.isfinite(quiet))}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("command", choices=("collect", "report", "analyse"))
    ap.add_argument("--shard", default="0/1")
    a = ap.parse_args()
    sys.exit({"collect": lambda: collect(a.shard), "report": report, "analyse": analyse}[a.command]())
