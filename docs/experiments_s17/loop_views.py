"""Seventeenth session, tuning data only: the picking loop's own views, for the region verifier.

The shipped verifier (impurity_attention.core.verifier) was fitted on first views: scenes as they are
dropped, before any action. The sixteenth session found most failed invisible grasps are TARGETs on product
pieces after pushes (docs/experiments_s16/grasps_screening.txt), on views the verifier never saw. This
script runs truth-counted episodes of the shipped network under the `cell` rules on tuning palettes and
fresh tuning seeds (SEED_BASE + k, registered in impurity_learning.splits) and keeps every view the loop
decided on, with the simulator's body-id segmentation projected onto the same heightmap grid: each view is
a SceneRecord that scripts/calibrate_attention.py reads as it reads first views.

A view's record gets the scenario its truth makes it (SceneRecord.category()): "random" when a target shows
at least evaluation.MIN_VISIBLE_CELLS cells (visible), "invisible" when targets are left but hidden, and
no target ids when none is left (no_impurity). Its seed is 100 x the episode's seed + the view's index;
the episode's own scenario, seed and palette go to the .jsonl beside the .npz.

    python docs/experiments_s17/loop_views.py collect invisible 160 runs/s17/views_inv.npz
    python docs/experiments_s17/loop_views.py collect challenging 80 runs/s17/views_chal.npz --start 200
    python docs/experiments_s17/loop_views.py collect random 80 runs/s17/views_rand.npz --start 400
    # the screen: a model fitted with the even-index palettes' views, judged on the odd-index ones
    python docs/experiments_s17/loop_views.py subset even runs/s17/views_even.npz \
        runs/s17/views_inv.npz runs/s17/views_chal.npz runs/s17/views_rand.npz
    python docs/experiments_s17/loop_views.py subset odd runs/s17/views_odd.npz \
        runs/s17/views_inv.npz runs/s17/views_chal.npz runs/s17/views_rand.npz
    python scripts/calibrate_attention.py verifier-fit --own-layouts --loop-views runs/s17/views_even.npz \
        --model-json runs/s17/verifier_even.json
    python docs/experiments_s17/loop_views.py decisions runs/s17/views_odd.npz [--verifier model.json]
"""
import argparse
import dataclasses
import json
import pathlib
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "experiments_s14"))
import push_out  # noqa: E402  (its tuning palettes)

SEED_BASE = 10_000  # episode k's seed: SEED_BASE + k (splits.TUNING_SEED_BLOCKS)
_WORKER = {}


def view_record(scenario: str, seed: int, palette: str, maps, truth, grid):
    """A loop view as a SceneRecord (module docstring)."""
    from impurity_attention.core import evaluation
    targets = tuple(int(b) for b in truth.target_ids if b in truth.poses)
    shown = int(np.count_nonzero(np.isin(maps.labels, list(targets)))) if targets else 0
    kind = "random" if shown >= evaluation.MIN_VISIBLE_CELLS else ("invisible" if targets else scenario)
    cells = tuple(grid.base_to_pixel(*truth.poses[b][0][:2]) for b in targets)
    return evaluation.SceneRecord(kind, seed, len(targets), len(truth.object_ids), maps.color.copy(),
                                  maps.height.copy(), maps.labels.astype(np.int32), targets, cells, palette)


def run_one(task: tuple):
    scenario, seed, palette = task
    import torch

    from impurity_attention.core.attention import AttentionParams
    from impurity_learning.agents import NetworkAgent
    from impurity_learning.evaluate import SimCell
    from impurity_policy.core import picking
    from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
    from impurity_policy.core.episode import EpisodeRequest
    from impurity_policy.core.policy import Policy
    from impurity_policy.core.rules import RuleParams, RulePipeline
    from ur5_driver_sim.core.world import CellWorld

    if "world" not in _WORKER:
        torch.set_num_threads(1)
        world = CellWorld(mode="floating")
        render = world.render

        def keeping_render():
            _WORKER["frame"] = render()
            return _WORKER["frame"]

        world.render = keeping_render
        _WORKER["world"] = world
        rules = RulePipeline.preset("cell", RuleParams())
        _WORKER["agent"] = NetworkAgent("ours", Policy.from_checkpoint(SHIPPED_CHECKPOINT, rules=rules))
    views = []

    class ViewCell(SimCell):
        """SimCell that keeps every view with its segmentation (the frame attention was run on)."""

        def _sense(self):
            super()._sense()
            frame = _WORKER["frame"]
            maps = self._projectors["camera"].project(frame.color, frame.depth, labels=frame.segmentation)
            views.append(view_record(scenario, 100 * seed + len(views), palette, maps,
                                     self._sensed.truth, self.grid))

    summary = picking.run_episode(ViewCell(_WORKER["world"], _WORKER["agent"], AttentionParams()),
                                  EpisodeRequest(scenario, seed=seed, palette=palette), f"{scenario}-{seed}",
                                  on_error=lambda e: (_ for _ in ()).throw(e))
    meta = {"scenario": scenario, "seed": seed, "palette": palette, "views": len(views),
            "completed": summary["completed"], "attempts": summary["grasp_attempts"],
            "picked": summary["targets_picked"], "actions": summary["actions"]}
    return views, meta


def collect(args) -> None:
    from tqdm import tqdm

    from impurity_attention.core import evaluation
    names = collection_palettes(args.random_palettes)
    tasks = [(args.scenario, args.seed_base + k, names[k % len(names)])
             for k in range(args.start, args.start + args.episodes)]
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    records = []
    with ProcessPoolExecutor(args.jobs) as pool, open(out.with_suffix(".jsonl"), "w") as f:
        for views, meta in tqdm(pool.map(run_one, tasks), total=len(tasks), desc=out.stem):
            records += views
            f.write(json.dumps(meta) + "\n")
            f.flush()
    evaluation.save_records(out, records)
    print(f"{len(records)} views of {len(tasks)} episodes -> {out}")


def collection_palettes(random_palettes: int = 100) -> list:
    """The palettes collect cycles through, episode k on entry k % len."""
    return push_out.palettes(random_palettes) + ["blocks"]


def subset(args) -> None:
    """The views of the palettes at even (or odd) indices of collection_palettes(), for the screen."""
    from impurity_attention.core import evaluation
    keep = set(collection_palettes()[args.parity == "odd"::2])
    records = [r for r in load_views(args.files) if r.palette in keep]
    evaluation.save_records(args.out, records)
    print(f"{len(records)} views of {len(keep)} {args.parity}-index palettes -> {args.out}")


def load_views(paths) -> list:
    from impurity_attention.core import evaluation
    return [r for path in paths for r in evaluation.load_records(path)]


def decisions(records, params) -> dict:
    """Counts of attention's decisions on loop views, over views showing a target (visible: at least
    evaluation.MIN_VISIBLE_CELLS cells) and views showing none (hidden: targets left but hidden, or none
    left): [views, TARGET on a target's cells, TARGET off every target's cells]."""
    from impurity_attention.core.attention import AttentionMode, attend
    counts = {"visible": [0, 0, 0], "hidden": [0, 0, 0]}
    for record in records:
        kind = "visible" if record.category() == "visible" else "hidden"
        output = attend(record.color, record.height, params)
        counts[kind][0] += 1
        if int(output.mode) == AttentionMode.TARGET:
            on = bool(np.any(output.target_mask & record.visible_target_cells))
            counts[kind][1 if on else 2] += 1
    return counts


def print_decisions(counts: dict, label: str) -> None:
    (views, on, off), (hidden, hidden_on, false) = counts["visible"], counts["hidden"]
    print(f"{label}:\n  views showing a target {views}: TARGET on it {on} "
          f"({100 * on / max(views, 1):.1f} %), "
          f"TARGET off every target {off}\n  views showing none {hidden}: TARGET off every target {false} "
          f"({100 * false / max(hidden, 1):.1f} %), on a target's few visible cells {hidden_on}\n"
          f"  TARGETs off every target in all: {off + false}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("collect")
    c.add_argument("scenario")
    c.add_argument("episodes", type=int)
    c.add_argument("out")
    c.add_argument("--start", type=int, default=0)
    c.add_argument("--seed-base", type=int, default=SEED_BASE)
    c.add_argument("--random-palettes", type=int, default=100)
    c.add_argument("--jobs", type=int, default=2)
    d = sub.add_parser("decisions", help="attention's decisions on collected views")
    d.add_argument("files", nargs="+")
    d.add_argument("--verifier", help="a RegionVerifier as JSON (default: the shipped model)")
    s = sub.add_parser("subset", help="the views of the even- or odd-index palettes")
    s.add_argument("parity", choices=("even", "odd"))
    s.add_argument("out")
    s.add_argument("files", nargs="+")
    args = p.parse_args(argv)
    if args.command == "collect":
        collect(args)
    elif args.command == "subset":
        subset(args)
    else:
        from impurity_attention.core.attention import AttentionParams
        params = AttentionParams()
        if args.verifier:
            params = dataclasses.replace(params, verifier=push_out.verifier_from_json(args.verifier))
        print_decisions(decisions(load_views(args.files), params), args.verifier or "shipped verifier")
    return 0


if __name__ == "__main__":
    sys.exit(main())
