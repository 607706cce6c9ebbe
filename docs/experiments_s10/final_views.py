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


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("command", choices=("collect", "report"))
    ap.add_argument("--shard", default="0/1")
    a = ap.parse_args()
    sys.exit(collect(a.shard) if a.command == "collect" else report())
