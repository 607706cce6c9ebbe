#!/usr/bin/env python3
"""Choose the height below which a dense cluster cannot hide anything (attention's
DensityParams.min_cluster_height) by how episodes counted as a real cell counts end (issue 18).

A cell without target counts ends an episode when attention answers NONE: no visible impurity and no
cluster that could hide one (paper Fig. 5). A threshold too low keeps a flattened heap "open" forever
(one layer of upright bars and pillars, 3.2-3.6 cm, hides nothing), and the episode runs into its action
limit or into repeated failed grasps; one too high calls a heap that still covers an impurity empty,
and the episode ends with the impurity left. So it is judged by the episodes' ends:

  clean end       attention's NONE ended the episode and the simulator's truth has no impurity left
  ended by NONE   the end a real cell needs (any other end is a limit of the loop)
  left behind     ended by NONE with an impurity still in the workspace (the truth's count)

`collect` runs fast-sim episodes (evaluate.PerceptionSimCell: no count, attention's NONE ends them, the
shipped network with the `cell` rules decides) for every height on the same scenes; `report` prints the
figures per height, palette group and scene, and chooses on the TUNING episodes the height with the most
clean ends on the scenes every height ran (ties: the lowest). Evaluation seeds and held-out palettes are
only ever measured (`--split evaluation`).

    python scripts/calibrate_episode_end.py collect --split tuning --out runs/episode_end/tuning.jsonl
    python scripts/calibrate_episode_end.py report runs/episode_end/tuning.jsonl
"""

from __future__ import annotations

import argparse
import dataclasses
import gzip
import itertools
import json
import pathlib
import sys

import numpy as np
from tqdm import tqdm

from impurity_attention.core.attention import AttentionParams
from impurity_learning import splits
from impurity_learning.agents import make_agent
from impurity_learning.evaluate import PerceptionSimCell, _reraise
from impurity_policy.core import picking
from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
from impurity_policy.core.episode import TERMINATION_NOTHING_LEFT, EpisodeRequest

HEIGHTS = (0.030, 0.035, 0.040, 0.045)  # m, the thresholds `collect` tries by default
# (scenario, num_targets, num_objects, max_actions): the real-cell-mode graph test's invisible scenes, the
# paper-sized invisible ones (two heaps, 20 products), random clutter (tilted blocks make low clusters), and
# the graph test's small random and challenging scenes. Appended, never reordered: a scene's seeds follow
# its index.
SCENES = (("invisible", 1, 10, 45), ("invisible", 2, 20, 45), ("random", 2, 10, 25), ("random", 1, 5, 15),
          ("challenging", 1, 5, 15))
# Seeds apart from the attention calibration's (0.., 1000..), the verdict calibration's (50 000.., EVAL +
# 500 000..) and the real-cell graph test's (EVAL + 700 000.., + 800 000..).
SEED_BASE = {"tuning": 60_000, "evaluation": splits.EVAL_SEED_BASE + 600_000}


def jobs_of(split: str, heights, seeds: int, random_palettes: int) -> list:
    """[(height, scene, palette, seed)]: every height on the same scenes."""
    palettes = (splits.tuning_palettes(random_palettes) if split == "tuning"
                else [splits.DEFAULT_PALETTE, *splits.held_out_palettes(random_palettes)])
    base = SEED_BASE[split]
    scenes = [(scene, palette, base + 100 * index + k) for index, scene in enumerate(SCENES)
              for k, palette in zip(range(seeds), itertools.cycle(palettes))]
    return [(height, *job) for height in heights for job in scenes]


def episode(world, agent, height: float, scene: tuple, palette: str, seed: int) -> dict:
    """One episode counted by perception with attention's min_cluster_height `height` (m)."""
    scenario, targets, objects, max_actions = scene
    base = AttentionParams()
    params = dataclasses.replace(base, density=dataclasses.replace(base.density, min_cluster_height=height))
    cell = PerceptionSimCell(world, agent, attention_params=params)
    request = EpisodeRequest(scenario, seed=seed, num_targets=targets, num_objects=objects,
                             max_actions=max_actions, palette=palette)
    summary = picking.run_episode(cell, request, f"{scenario}-{seed}", picking.EpisodeLimits(),
                                  on_error=_reraise)
    return {"height": height, "scenario": scenario, "num_targets": targets, "num_objects": objects,
            "palette": palette, "group": splits.palette_group(palette), "seed": seed,
            "termination": summary["termination_reason"], "actions": summary["actions"],
            "picked": summary["targets_picked"], "truth_picked": summary["truth_targets_picked"],
            "truth_total": summary["truth_targets_total"], "verdicts_checked": summary["verdicts_checked"],
            "verdicts_agreeing": summary["verdicts_agreeing"]}


def key_of(row: dict) -> tuple:
    return (row["height"], row["scenario"], row["num_targets"], row["num_objects"], row["palette"],
            row["seed"])


def collect(args) -> int:
    import torch

    from ur5_driver_sim.core.world import CellWorld

    torch.set_num_threads(args.threads)
    jobs = jobs_of(args.split, args.heights, args.seeds, args.random_palettes)[args.shard::args.shards]
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = {key_of(row) for row in read(out)} if out.exists() else set()
    world = CellWorld(mode="floating")
    agent = make_agent("ours", pathlib.Path(args.checkpoint), "cell")
    with out.open("a") as sink:
        for height, scene, palette, seed in tqdm(jobs, desc="episodes"):
            if (height, scene[0], scene[1], scene[2], palette, seed) in done:
                continue
            sink.write(json.dumps(episode(world, agent, height, scene, palette, seed)) + "\n")
            sink.flush()
    return 0


def read(path) -> list:
    path = pathlib.Path(path)
    text = gzip.decompress(path.read_bytes()).decode() if path.suffix == ".gz" else path.read_text()
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def figures(rows: list) -> dict:
    """Shares of clean ends, ends by NONE and completed episodes; episodes that ended by NONE with an
    impurity left; mean actions; episodes whose perception count equals the truth's; grasp verdicts that
    agree with the truth."""
    n = len(rows)
    by_none = [r["termination"] == TERMINATION_NOTHING_LEFT for r in rows]
    complete = [r["truth_picked"] >= r["truth_total"] for r in rows]
    return {"episodes": n,
            "clean_end": sum(a and b for a, b in zip(by_none, complete, strict=True)) / max(n, 1),
            "ended_by_none": sum(by_none) / max(n, 1),
            "left_behind": sum(a and not b for a, b in zip(by_none, complete, strict=True)),
            "completion": sum(complete) / max(n, 1),
            "actions": float(np.mean([r["actions"] for r in rows])) if rows else 0.0,
            "count_match": sum(r["picked"] == r["truth_picked"] for r in rows) / max(n, 1),
            "verdicts": sum(r["verdicts_agreeing"] for r in rows)
            / max(sum(r["verdicts_checked"] for r in rows), 1)}


def scene_of(row: dict) -> tuple:
    return row["scenario"], row["num_targets"], row["num_objects"], row["palette"], row["seed"]


def common_scenes(rows: list) -> list:
    """The rows of the scenes every height ran: heights are compared on the same scenes only."""
    heights = {r["height"] for r in rows}
    shared = set.intersection(*({scene_of(r) for r in rows if r["height"] == h} for h in heights))
    return [r for r in rows if scene_of(r) in shared]


def choose(rows: list) -> float:
    """The tuning rows' min_cluster_height with the most clean ends on the scenes every height ran; ties go
    to the lowest (the least that a real cell is told to ignore)."""
    rows = common_scenes(rows)

    def clean_ends(height):
        return round(figures([r for r in rows if r["height"] == height])["clean_end"], 6)

    return max(sorted({r["height"] for r in rows}), key=lambda h: (clean_ends(h), -h))


def line(height: float, name: str, rows: list) -> str:
    f = figures(rows)
    return (f"{height:18.3f}  {name:22s} {f['episodes']:8d}  {f['clean_end']:9.1%}  "
            f"{f['ended_by_none']:13.1%}  {f['left_behind']:11d}  {f['completion']:10.1%}  "
            f"{f['actions']:7.1f}  {f['count_match']:11.1%}  {f['verdicts']:8.1%}")


def report(args) -> int:
    rows = [row for path in args.files for row in read(path)]
    if not rows:
        print("report: no episodes in the files", file=sys.stderr)
        return 2
    tuning = [r for r in rows
              if r["group"] in ("default", "tuning") and r["seed"] in splits.TUNING_SEED_RANGE]
    chosen = choose(tuning) if tuning else None
    print("min_cluster_height  scenes                 episodes  clean_end  "
          "ended_by_NONE  left_behind  completion  actions  count_match  verdicts")
    for group in sorted({r["group"] for r in rows}):
        print(f"== palettes: {group}")
        for height in sorted({r["height"] for r in rows}):
            of = [r for r in rows if r["group"] == group and r["height"] == height]
            for s, t, o, _ in SCENES:
                subset = [r for r in of if (r["scenario"], r["num_targets"], r["num_objects"]) == (s, t, o)]
                if subset:
                    print(line(height, f"{s} {t}/{o}", subset))
            if of:
                print(line(height, "all", of))
    if chosen is not None:
        shared = common_scenes(tuning)
        print("== the choice: default and tuning palettes, tuning seeds, the scenes every height ran")
        for height in sorted({r["height"] for r in shared}):
            print(line(height, "all", [r for r in shared if r["height"] == height]))
        print(f"chosen on the tuning episodes (most clean ends; ties to the lowest): min_cluster_height "
              f"{chosen:.3f} m")
    return 0


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("collect", help="run episodes counted by perception per threshold (resumable)")
    c.add_argument("--split", choices=tuple(SEED_BASE), required=True,
                   help="tuning: tuning palettes and seeds; evaluation: default and held-out palettes, "
                        "evaluation seeds (only measured)")
    c.add_argument("--heights", type=float, nargs="+", default=list(HEIGHTS), help="min_cluster_height (m)")
    c.add_argument("--seeds", type=int, default=8, help="episodes per scene size")
    c.add_argument("--random-palettes", type=int, default=4, help="random palettes of the split")
    c.add_argument("--checkpoint", default=str(SHIPPED_CHECKPOINT))
    c.add_argument("--threads", type=int, default=1, help="torch threads")
    c.add_argument("--shard", type=int, default=0, help="run every --shards-th job from this one")
    c.add_argument("--shards", type=int, default=1, help="processes sharing the jobs (each its own --out)")
    c.add_argument("--out", required=True, help="JSON lines, one episode each (appended: resumable)")
    r = sub.add_parser("report", help="figures per height, scene and palette group")
    r.add_argument("files", nargs="+")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    return {"collect": collect, "report": report}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
