#!/usr/bin/env python3
"""Choose the grasp verdict's thresholds (impurity_policy/core/verdict.py) on tuning scenes, then measure
them on evaluation seeds and held-out palettes (issue 18: a real cell judges each grasp by perception).

Runs episodes in the fast simulator counted as a real cell counts (evaluate.run_episode(by_perception=True):
no target count, attention's NONE ends them, the shipped network with the `cell` rules decides), collects
every grasp of an attended TARGET with what perception knew when judging it, beside the simulator's truth
(did the grasp remove an impurity?):

  target_score    attention's saliency contrast of the attended region (AttentionResult.score)
  gone_fraction   share of the target's cells changed in the next view (verdict.target_gone_fraction)
  holding         the gripper's report after the lift
  color_contrast  the attended region's colour distance from the product (verdict.ProductReference.contrast:
                  Mahalanobis, palette-relative, no RGB constant), the product as the episode's first view
                  showed it, as the loop judges; computed when loading from the raw colours kept in the
                  files (the region's mean RGB, every 8th product cell of the first view), so a change of
                  the measure needs no new episodes

The gone and holding tests are kept as they are (geometry: they do not depend on the palette); `sweep`
chooses min_color_contrast (with the product's least colour spread and shading) by the agreement of the
verdict with the truth on the TUNING grasps only (palettes and seeds of impurity_learning.splits), and
`measure` reports the chosen thresholds on fresh evaluation seeds, default and held-out palettes, without
changing anything.

    python scripts/calibrate_verdict.py collect --split tuning --out runs/verdict/tuning.jsonl
    python scripts/calibrate_verdict.py sweep runs/verdict/tuning.jsonl
    python scripts/calibrate_verdict.py collect --split evaluation --out runs/verdict/evaluation.jsonl
    python scripts/calibrate_verdict.py measure runs/verdict/evaluation.jsonl --min-color-contrast C

The episodes behind docs/verdict/*.txt are kept gzipped beside them (tuning.jsonl.gz, evaluation.jsonl.gz,
exposure.jsonl.gz): `sweep` and `measure` read them as they are.
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

from impurity_learning import splits
from impurity_learning.agents import make_agent
from impurity_learning.evaluate import PerceptionSimCell, _reraise
from impurity_policy.core import picking
from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
from impurity_policy.core.episode import TERMINATION_NOTHING_LEFT, EpisodeRequest
from impurity_policy.core.verdict import (
    COLOR_SHADING,
    MIN_COLOR_SPREAD,
    ProductReference,
    VerdictParams,
    decide_picked,
    product_color_distance,
    product_reference,
    region_color,
)

SCENARIOS = ("random", "challenging", "invisible")
SPREADS = (2, 4, 8, 12, 16, 20, 24, 32, 40, 48)  # least product colour spreads (RGB) the sweep tries
SHADINGS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)  # ProductReference shadings (share of the mean colour) it tries
# (num_targets, num_objects, max_actions) per scenario: the real-cell-mode graph test's small scenes and
# the paper-sized ones (more products left when the last impurity is gone: more chances of a false TARGET).
SCENE_SIZES = {"random": [(1, 5, 15), (2, 10, 25)], "challenging": [(1, 5, 15), (2, 10, 25)],
               "invisible": [(1, 10, 45)]}
# Without the colour threshold: every grasp that passes the gone and holding tests is counted.
UNTHRESHOLDED = VerdictParams(min_color_contrast=0.0)


class RecordingCell(PerceptionSimCell):
    """PerceptionSimCell that keeps the view each grasp was decided on, for the features."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.last_view = None
        self.decided_on = None
        self.reference = None  # as picking's loop builds it: from the episode's first view

    def observe(self):
        self.last_view = super().observe()
        if self.reference is None:
            view = self.last_view
            self.reference = product_reference(view.color, view.height, view.target_mask)
        return self.last_view

    def execute(self, action):
        self.decided_on = self.last_view
        return super().execute(action)


def palettes_of(split: str, random_count: int) -> list:
    if split == "tuning":
        return splits.tuning_palettes(random_count)
    if split == "exposure":  # the default palette one stop darker and brighter (evaluation seeds)
        return [f"{splits.DEFAULT_PALETTE}@x0.5", f"{splits.DEFAULT_PALETTE}@x2"]
    return [splits.DEFAULT_PALETTE, *splits.held_out_palettes(random_count)]


def seeds_of(split: str, count: int) -> list:
    """Tuning seeds 50 000+ (apart from the attention calibration's and the graph tests' small seeds);
    evaluation seeds EVAL_SEED_BASE + 500 000+ (apart from make eval's first ones and the graph test's)."""
    base = 50_000 if split == "tuning" else splits.EVAL_SEED_BASE + 500_000
    return [base + k for k in range(count)]


def collect(args) -> int:
    import torch

    from ur5_driver_sim.core.world import CellWorld

    torch.set_num_threads(args.threads)
    palettes = palettes_of(args.split, args.random_palettes)
    seeds = seeds_of(args.split, args.seeds)
    jobs = [(scenario, size, palette, seed) for scenario in SCENARIOS for size in SCENE_SIZES[scenario]
            for palette, seed in zip(itertools.cycle(palettes), seeds)][args.shard::args.shards]
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if out.exists():  # resume: episodes already written are skipped
        for line in out.read_text().splitlines():
            row = json.loads(line)
            done.add((row["scenario"], row["num_objects"], row["palette"], row["seed"]))
    world = CellWorld(mode="floating")
    agent = make_agent("ours", pathlib.Path(args.checkpoint), "cell")
    limits = picking.EpisodeLimits(verdict=UNTHRESHOLDED)
    with out.open("a") as sink:
        for scenario, (targets, objects, max_actions), palette, seed in tqdm(jobs, desc="episodes"):
            if (scenario, objects, palette, seed) in done:
                continue
            cell = RecordingCell(world, agent)
            grasps = []

            def on_step(step, cell=cell, grasps=grasps):
                view = cell.decided_on
                if step.kind != "grasp":
                    return
                if view is None or view.target_mask is None:  # not a TARGET: never counted as picked
                    grasps.append({"step": step.step, "target": False,
                                   "truth": bool(step.truth_target_grasped)})
                    return
                grasps.append({"target": True,
                    "step": step.step, "target_score": step.target_score, "gone_fraction": step.gone_fraction,
                    "holding": bool(step.holding), "truth": bool(step.truth_target_grasped),
                    "color_distance": product_color_distance(view.color, view.height, view.target_mask),
                    "region_rgb": region_color(view.color, view.target_mask).round(1).tolist()})

            request = EpisodeRequest(scenario, seed=seed, num_targets=targets, num_objects=objects,
                                     max_actions=max_actions, palette=palette)
            summary = picking.run_episode(cell, request, f"{scenario}-{seed}", limits, on_step=on_step,
                                          on_error=_reraise)
            row = {"scenario": scenario, "num_objects": objects, "palette": palette, "seed": seed,
                   "group": splits.palette_group(palette), "termination": summary["termination_reason"],
                   "truth_total": summary["truth_targets_total"], "grasps": grasps,
                   # the product reference's colours (every 8th kept): measures can be compared offline
                   "reference_rgb": cell.reference.colors[::8].round().astype(int).tolist()
                   if cell.reference is not None else []}
            sink.write(json.dumps(row) + "\n")
            sink.flush()
    return 0


def load(paths, min_spread: float = MIN_COLOR_SPREAD, shading: float = COLOR_SHADING) -> list:
    """Episodes of the files, each TARGET grasp's color_contrast computed from the raw colours with a
    ProductReference of the given least spread (RGB) and shading."""
    rows = []
    for path in map(pathlib.Path, paths):
        text = gzip.decompress(path.read_bytes()).decode() if path.suffix == ".gz" else path.read_text()
        rows += [json.loads(line) for line in text.splitlines() if line.strip()]
    return with_contrast(rows, min_spread, shading)


def with_contrast(rows: list, min_spread: float, shading: float = 0.0) -> list:
    for row in rows:
        colors = row["reference_rgb"]
        reference = ProductReference.from_colors(colors, min_spread, shading) if colors else None
        for grasp in row["grasps"]:
            if grasp["target"]:
                grasp["color_contrast"] = reference.contrast(grasp["region_rgb"]) if reference else None
    return rows


def verdict(grasp: dict, min_contrast: float, params: VerdictParams = VerdictParams()) -> bool:
    """judge_grasp's decision (verdict.decide_picked) on a recorded grasp's features, at the threshold
    min_contrast (min_color_contrast); a grasp without an attended target is never a pick."""
    if not grasp["target"]:
        return False
    tried = dataclasses.replace(params, min_color_contrast=min_contrast)
    return decide_picked(grasp["gone_fraction"], grasp["holding"], grasp["color_contrast"], tried)[0]


def agreement(rows: list, min_contrast: float) -> dict:
    """Grasp verdicts agreeing with the truth, and episodes whose picked count equals the truth's."""
    checked = agreeing = episodes = matching = missed = false = 0
    for row in rows:
        picked = truth_picked = 0
        for grasp in row["grasps"]:
            decided = verdict(grasp, min_contrast)
            checked += 1
            agreeing += decided == grasp["truth"]
            missed += grasp["truth"] and not decided
            false += decided and not grasp["truth"]
            picked += decided
            truth_picked += grasp["truth"]
        episodes += 1
        matching += picked == truth_picked
    return {"grasps": checked, "agreement": agreeing / max(checked, 1), "missed": missed, "false": false,
            "episodes": episodes, "count_match": matching / max(episodes, 1)}


def sweep(args) -> int:
    rows = [r for r in load(args.files) if r["group"] in ("default", "tuning")]
    if len(rows) < len(load(args.files)):
        print("sweep: rows of held-out palettes ignored (they are only measured)", file=sys.stderr)
    grasps = [g for r in rows for g in r["grasps"] if g["target"]]
    if not grasps:
        print("sweep: no judged grasps in the files", file=sys.stderr)
        return 2
    truths = [g for g in grasps if g["truth"]]
    others = [g for g in grasps if not g["truth"] and g["gone_fraction"] >= 0.5 and g["holding"]]
    untargeted = sum(not g["target"] and g["truth"] for r in rows for g in r["grasps"])
    print(f"{len(rows)} tuning episodes, {len(grasps)} grasps of a TARGET: {len(truths)} removed an "
          f"impurity, {len(others)} lifted something else that the gone and holding tests pass; "
          f"{untargeted} grasps without a TARGET removed one (never counted: they disagree whatever "
          "the thresholds)")
    for name in ("target_score", "color_contrast"):
        for label, subset in (("impurity", truths), ("other", others)):
            values = np.array([g[name] for g in subset if g[name] is not None], dtype=float)
            if values.size:
                print(f"  {name:14s} {label:8s} min {values.min():6.2f}  p5 {np.percentile(values, 5):6.2f}  "
                      f"median {np.median(values):6.2f}  p95 {np.percentile(values, 95):6.2f}  "
                      f"max {values.max():6.2f}")
    contrasts = np.round(np.arange(0.0, 6.01, 0.25), 2)
    # Best agreement; ties broken by the episode count match, then by the lowest threshold (fewest true
    # impurities refused on scenes unlike the tuning ones), the least spread (most relative) and the
    # least shading.

    def key(t):
        return round(t[2]["agreement"], 4), round(t[2]["count_match"], 4), -t[1], -t[0], -t[3]

    print("shading  least spread (RGB)  min_color_contrast  agreement  missed  false  count_match")
    best_of = []
    for shading in SHADINGS:
        for spread in SPREADS:
            with_contrast(rows, spread, shading)
            table = [(spread, c, agreement(rows, c), shading) for c in contrasts]
            best_of.append(max(table, key=key))
    best = max(best_of, key=key)
    for spread, c, a, shading in best_of:
        mark = "  <- chosen" if (spread, shading) == (best[0], best[3]) else ""
        print(f"{shading:7.1f}  {spread:18.0f} {c:19.2f}  {a['agreement']:9.1%}  {a['missed']:6d}  "
              f"{a['false']:5d}  {a['count_match']:10.1%}{mark}")
    with_contrast(rows, best[0], best[3])
    print(f"at least spread {best[0]:.0f}, shading {best[3]:.1f}:")
    print("min_color_contrast  agreement  missed  false  count_match")
    for c in (0.0, 1.0, best[1], 3.0):
        a = agreement(rows, c)
        print(f"{c:18.2f}  {a['agreement']:9.1%}  {a['missed']:6d}  {a['false']:5d}  "
              f"{a['count_match']:10.1%}")
    spread, contrast, figures, shading = best
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(
            {"chosen": {"min_color_spread": spread, "shading": shading, "min_color_contrast": contrast,
                        **figures},
             "episodes": len(rows), "files": [str(f) for f in args.files]}, indent=1) + "\n")
    return 0


def measure(args) -> int:
    rows = load(args.files, args.min_color_spread, args.shading)
    print(f"min_color_contrast {args.min_color_contrast}, least "
          f"colour spread {args.min_color_spread}, shading {args.shading}")
    print("palettes            scenario      episodes grasps agreement missed false count_match "
          "ended_by_NONE")
    groups = [(g, lambda r, g=g: r["group"] == g and "@" not in r["palette"])
              for g in ("default", "tuning", "held_out")]
    groups += [(f"default {e}", lambda r, e=e: r["palette"].endswith("@" + e)) for e in ("x0.5", "x2")]
    for group, member in groups:
        for scenario in (*SCENARIOS, "all"):
            subset = [r for r in rows if member(r) and scenario in ("all", r["scenario"])]
            if not subset:
                continue
            a = agreement(subset, args.min_color_contrast)
            ended = np.mean([r["termination"] == TERMINATION_NOTHING_LEFT for r in subset])
            print(f"{group:19s} {scenario:12s} {a['episodes']:9d} {a['grasps']:6d} {a['agreement']:9.1%} "
                  f"{a['missed']:6d} {a['false']:5d} {a['count_match']:11.1%} {ended:13.1%}")
    return 0


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("collect", help="run episodes counted by perception, write their grasps (resumable)")
    c.add_argument("--split", choices=("tuning", "evaluation", "exposure"), required=True,
                   help="tuning: tuning palettes and seeds; evaluation: default and held-out palettes, "
                        "evaluation seeds; exposure: the default palette at x0.5 and x2, evaluation seeds")
    c.add_argument("--seeds", type=int, default=12, help="episodes per scene size and scenario")
    c.add_argument("--random-palettes", type=int, default=4, help="random palettes of the split")
    c.add_argument("--checkpoint", default=str(SHIPPED_CHECKPOINT))
    c.add_argument("--threads", type=int, default=1, help="torch threads")
    c.add_argument("--shard", type=int, default=0, help="run every --shards-th episode from this one")
    c.add_argument("--shards", type=int, default=1,
                   help="processes sharing the episodes (each its own --out)")
    c.add_argument("--out", required=True, help="JSON lines, one episode each (appended: resumable)")
    s = sub.add_parser("sweep", help="choose the thresholds on the tuning episodes of the files")
    s.add_argument("files", nargs="+")
    s.add_argument("--json", help="write the chosen thresholds and figures here")
    m = sub.add_parser("measure", help="agreement of given thresholds per palette group and scenario")
    m.add_argument("files", nargs="+")
    m.add_argument("--min-color-contrast", type=float, required=True)
    m.add_argument("--min-color-spread", type=float, default=MIN_COLOR_SPREAD)
    m.add_argument("--shading", type=float, default=COLOR_SHADING)
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    return {"collect": collect, "sweep": sweep, "measure": measure}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
