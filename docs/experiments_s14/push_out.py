"""Fourteenth session, tuning data only: which actions push a target out of the workspace.

Runs truth-counted episodes of the shipped network under the `cell` rules on tuning palettes (the tuning
group's named palettes and random-400...) and tuning seeds (99000 + k), and records every action after which
the count of targets outside the workspace rose: attention's mode, the primitive, where the push started and
ended and how far that end lay inside the workspace. Variants of the rules (`--without`, `--edge-margin`,
`--push-end-margin`) are run on the same seeds, so a change can be chosen on them.

    # the rules then shipped (push_out_base.jsonl was run before the new rule existed, so its params are {};
    # since the fifteenth session the rule is on by default: the same rules today are --edge-margin 0)
    python docs/experiments_s14/push_out.py run invisible 200 runs/s14/push_out_base.jsonl --edge-margin 0
    python docs/experiments_s14/push_out.py run invisible 200 runs/s14/push_out_e12.jsonl --edge-margin 0.12
    python docs/experiments_s14/push_out.py report runs/s14/push_out_base.jsonl runs/s14/push_out_e12.jsonl
    python docs/experiments_s14/push_out.py paired runs/s14/push_out_base.jsonl runs/s14/push_out_e12.jsonl
    # fifteenth session's second test, fresh seeds 99200-99599 (--start 200) and challenging 99600-99799
    # (--start 600), run while the rule was off by default; the rule was then adopted, so the defaults
    # ("shipped" in the reports: params {}) hold it since, and the base arm today is --edge-margin 0
    python docs/experiments_s14/push_out.py run invisible 400 runs/s15/inv_base.jsonl --start 200 \
        --edge-margin 0
    # sixteenth session: every grasp recorded ("grasps"), tuning palettes and the default palette on the same
    # fresh seeds 99800-99999 (--start 800), then `grasps` to sort the failed ones
    python docs/experiments_s14/push_out.py run invisible 200 runs/s16/grasps_tuning.jsonl --start 800
    python docs/experiments_s14/push_out.py run invisible 200 runs/s16/grasps_default.jsonl --start 800 \
        --palette blocks
    python docs/experiments_s14/push_out.py grasps runs/s16/grasps_tuning.jsonl runs/s16/grasps_default.jsonl
    # seventeenth session: the verifier refitted with loop views (experiments_s17/loop_views.py), fresh seeds
    # 11000+: invisible k < 200, challenging 200 <= k < 400, shipped and refitted verifier on the same seeds
    python docs/experiments_s14/push_out.py run invisible 200 runs/s17/pick_inv_base.jsonl --seed-base 11000
    python docs/experiments_s14/push_out.py run invisible 200 runs/s17/pick_inv_loop.jsonl --seed-base 11000 \
        --verifier runs/s17/verifier_loop.json
    # sixteenth session's test of attention's verifier_heap_threshold, fresh seeds 19000+ (--seed-base 19000):
    # invisible k < 200, challenging 200 <= k < 400, random 400 <= k < 600, with and without it, same seeds
    python docs/experiments_s14/push_out.py run invisible 200 runs/s16/heap_inv_base.jsonl --seed-base 19000
    python docs/experiments_s14/push_out.py run invisible 200 runs/s16/heap_inv_85.jsonl --seed-base 19000 \
        --heap-threshold 0.85
    python docs/experiments_s14/push_out.py run challenging 200 runs/s16/heap_chal_base.jsonl \
        --seed-base 19000 --start 200     # and the same with --heap-threshold 0.85
"""
import argparse
import dataclasses
import json
import math
import pathlib
import re
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

SEED_BASE = 99000
RANDOM_FROM = 400
_WORKER = {}


def palettes(count: int, start: int = RANDOM_FROM, named: bool = True) -> list:
    """The named tuning palettes (unless not `named`), then random-<start> ... random-<start + count - 1>,
    tuning palettes only (splits.tuning_random_palettes; the fresh ones from 2 000 000 too, 37th session)."""
    from impurity_learning import splits
    return (list(splits.TUNING_NAMED) if named else []) + splits.tuning_random_palettes(start, count)


def edge_distance(x: float, y: float) -> float:
    """m from (x, y) to the nearest workspace edge (negative outside)."""
    from impurity_common import cell
    (x_min, x_max), (y_min, y_max) = cell.WORKSPACE_X, cell.WORKSPACE_Y
    return min(x - x_min, x_max - x, y - y_min, y_max - y)


def nearest(poses: dict, ids, x: float, y: float) -> float:
    """m in the table plane from (x, y) to the nearest body of `ids` (inf when there is none)."""
    return min((math.hypot(poses[b][0][0] - x, poses[b][0][1] - y) for b in ids if b in poses),
               default=math.inf)


def verifier_from_json(path):
    """A RegionVerifier from calibrate_attention.py verifier-fit --model-json's file."""
    from impurity_attention.core.verifier import RegionVerifier
    return RegionVerifier.from_dict(json.loads(pathlib.Path(path).read_text()))


def run_one(task: tuple) -> dict:
    scenario, seed, palette, rule_params = task
    import torch

    from impurity_attention.core.attention import AttentionMode, AttentionParams
    from impurity_attention.core.density import find_clusters, select_occluded_region
    from impurity_common import cell
    from impurity_learning.agents import NetworkAgent
    from impurity_learning.evaluate import SimCell
    from impurity_learning.train import sensed_from
    from impurity_policy.core import picking
    from impurity_policy.core.checkpoint import SHIPPED_CHECKPOINT
    from impurity_policy.core.episode import EpisodeRequest
    from impurity_policy.core.policy import Policy
    from impurity_policy.core.rules import RuleParams, RulePipeline
    from ur5_driver_sim.core.world import CellWorld

    if "world" not in _WORKER:
        torch.set_num_threads(1)
        _WORKER["world"] = CellWorld(mode="floating")
    key = json.dumps(rule_params, sort_keys=True)
    if _WORKER.get("key") != key:
        attention_keys = ("without", "with", "verifier_heap_threshold", "verifier", "stall",
                          "stall_look_views", "verifier_last_look", "canonical_colours", "mask_truth",
                          "grasp_geometry", "temporal", "known_product", "near_miss",
                          "stall_look_threshold", "network")
        values = {k: v for k, v in rule_params.items() if k not in attention_keys}
        params = dataclasses.replace(RuleParams(), **values)
        preset = RulePipeline.preset("cell", params, without=rule_params.get("without", ()))
        canonical = ("canonical_colours",) if rule_params.get("canonical_colours") else ()
        rules = RulePipeline(preset.names + tuple(rule_params.get("with", ())) + canonical, params)
        _WORKER["agent"] = NetworkAgent("ours", Policy.from_checkpoint(SHIPPED_CHECKPOINT, rules=rules))
        _WORKER["key"] = key
    steps, where, decided = [], [], []
    known: dict = {}  # the known product's near miss (near_miss_truth), when the loop handed one over
    world = _WORKER["world"]

    stall = rule_params.get("stall")

    class RecordingCell(SimCell):
        """SimCell that keeps, for each decision, where the grasp point lay from the nearest target and the
        nearest product object (truth at decision time) and attention's mode. With `stall` (K, t), an
        experiment (eighteenth session): once attention has answered OCCLUDED_REGION for K views in a row,
        the view is attended again with verifier_threshold t, and the count starts over."""

        stalled = 0
        fired = False  # the current view's TARGET came from the stall-breaker

        previous = None  # the view before the current one (Sensed), for temporal()
        first = None  # the episode's first view (Sensed), for temporal()

        def reset(self, request):
            self.stalled = 0
            self._sensed = None
            targets = super().reset(request)
            self.first = self._sensed
            return targets

        def _sense(self):
            self.previous = self._sensed
            super()._sense()
            self.fired = False
            if stall is None:
                return
            if self._sensed.attention.mode != AttentionMode.OCCLUDED_REGION:
                self.stalled = 0
                return
            self.stalled += 1
            if self.stalled < stall[0]:
                return
            self.stalled = 0
            lowered = dataclasses.replace(self.attention_params, verifier_threshold=stall[1])
            # with the known product the first view handed over (twenty-seventh session; before it, none)
            self._sensed = sensed_from(self._sensed.maps, self._sensed.truth, self.agent.method, lowered,
                                       self.grid, self.known_product)
            self.fired = self._sensed.attention.mode == AttentionMode.TARGET

        def look_closer(self):
            """The loop's stall look (shipped since the thirty-first session): recorded as `stall` too."""
            view = super().look_closer()
            self.fired = self._sensed.attention.mode == AttentionMode.TARGET
            return view

        def know_product(self, view):
            super().know_product(view)
            if view is not None:  # twenty-seventh session: what a near miss would leave out, against the truth
                known.update(near_miss_truth(view.source.maps))

        def decide(self, view):
            action = super().decide(view)
            if action is not None:
                truth = world.ground_truth()
                poses = truth.poses
                x, y, _ = action.position
                attention = self._sensed.attention
                found = re.search(r"probability (\d+\.\d+)", attention.reason)
                heap = select_occluded_region(find_clusters(self._sensed.maps.height, self.grid.resolution,
                                                            self.attention_params.density))
                decided.append({"target_m": nearest(poses, truth.target_ids, x, y),
                                "object_m": nearest(poses, truth.object_ids, x, y),
                                "probability": float(found.group(1)) if found else None,
                                "last_look": bool(attention.last_look), "heap": heap is not None,
                                "stall": self.fired,
                                **(mask_truth(attention, truth) if with_mask_truth else {}),
                                **(temporal(attention, self._sensed.maps, self.previous, self.first)
                                   if with_temporal else {}),
                                **(grasp_geometry(action, truth) if with_geometry and action.kind == "grasp"
                                   else {})})
            return action

    with_mask_truth = bool(rule_params.get("mask_truth"))
    with_temporal = bool(rule_params.get("temporal"))

    def temporal(attention, maps, previous, first) -> dict:
        """Twenty-fifth session: what the target mask's cells were in the view before (a real cell has that
        view too; nothing here reads the simulator). t_first: no view before; t_prev_mode: attention's mode
        then; t_changed: the share of the mask's cells whose height moved by more than 5 mm; t_dcolour: the
        median colour change of its cells (RGB 0-255, Euclidean); t_prev_overlap: the share of the mask
        inside the previous view's target mask (None when that view had none); t_seen_4 / 8 / 12: the share of
        the episode's first view's object cells (5 mm above the table or more) whose colour lies within CIE76
        dE 4 / 8 / 12 of the mask's median colour (Lab), how common that colour was before anything moved."""
        mask = attention.target_mask
        if mask is None or not mask.any():
            return {}
        if previous is None:
            return {"t_first": True}
        before = previous.maps
        moved = np.abs(np.nan_to_num(maps.height[mask]) - np.nan_to_num(before.height[mask])) > 0.005
        dcolour = np.linalg.norm(maps.color[mask].astype(float) - before.color[mask].astype(float), axis=1)
        old = previous.attention.target_mask
        was_target = int(previous.attention.mode) == AttentionMode.TARGET
        overlap = round(float(old[mask].mean()), 3) if was_target and old is not None and old.any() else None
        from impurity_common.colour import lab, mask_colour

        region = mask_colour(maps.color, mask)
        objects = np.nan_to_num(first.maps.height) > 0.005
        distance = np.linalg.norm(lab(first.maps.color[objects]) - region, axis=1)
        seen = {f"t_seen_{r}": round(float((distance <= r).mean()), 4) if distance.size else 0.0
                for r in (4, 8, 12)}
        return {**seen, "t_first": False, "t_prev_mode": int(previous.attention.mode),
                "t_changed": round(float(moved.mean()), 3), "t_dcolour": round(float(np.median(dcolour)), 1),
                "t_prev_overlap": overlap}
    with_geometry = bool(rule_params.get("grasp_geometry"))

    def grasp_geometry(action, truth) -> dict:
        """Twenty-fourth session: the nearest target at a grasp decision, from the simulator (reads only; the
        episode is unchanged; truth: world.ground_truth() at the decision). g_shape, g_dims (m); g_tilt:
        degrees between its own z axis and the vertical; g_closing: degrees between the gripper's closing
        axis (the action's yaw) and the block's x axis, folded to [0, 90]; g_base: m from the table's top to
        the block's lowest corner (> 0: resting on something); g_touching: bodies in contact with it; g_over:
        the height (m) of their highest point above the target's top."""
        pb, poses = world.pb, truth.poses
        x, y, _ = action.position
        target = min(truth.target_ids, key=lambda b: math.hypot(poses[b][0][0] - x, poses[b][0][1] - y),
                     default=None)
        if target is None:
            return {}
        spec, orientation = world.specs[target], poses[target][1]
        rotation = np.array(pb.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        tilt = math.degrees(math.acos(min(1.0, abs(rotation[2, 2]))))
        block_yaw = math.atan2(rotation[1, 0], rotation[0, 0])
        closing = abs(math.degrees(action.yaw - block_yaw)) % 180.0
        closing = min(closing, 180.0 - closing)
        low, high = pb.getAABB(target)
        touching = {c[2] for c in pb.getContactPoints(bodyA=target) if c[2] in world.specs and c[2] != target}
        over = max((pb.getAABB(b)[1][2] - high[2] for b in touching), default=None)
        return {"g_shape": spec.shape, "g_dims": [round(d, 4) for d in spec.dims], "g_tilt": round(tilt, 1),
                "g_closing": round(closing, 1), "g_base": round(low[2] - pb.getAABB(world.table)[1][2], 4),
                "g_touching": len(touching), "g_over": None if over is None else round(over, 4)}

    def mask_truth(attention, truth) -> dict:
        """Twenty-third session: the target mask (m_t grown) and the salient region m_t against the truth,
        from a frame rendered with segmentation at decision time (no depth noise: the episode is unchanged).
        mask_precision: the share of the mask's cells that show a target; mask_cells: its size;
        mask_bodies: the bodies it covers with at least 10 cells; region_precision: the same share for m_t."""
        from impurity_attention.core.heightmap import rgbd_to_heightmaps
        from impurity_common.grid import HeightmapGrid
        if attention.target_mask is None or not attention.target_mask.any():
            return {}
        frame = world.render()
        labels = rgbd_to_heightmaps(frame.color, frame.depth, frame.intrinsics, frame.camera_pose,
                                    HeightmapGrid(), labels=frame.segmentation).labels
        targets = np.isin(labels, list(truth.target_ids))
        mask = attention.target_mask
        ids, counts = np.unique(labels[mask], return_counts=True)
        region = attention.target_region.mask if attention.target_region is not None else mask
        return {"mask_precision": round(float(targets[mask].mean()), 3), "mask_cells": int(mask.sum()),
                "mask_bodies": int(np.sum((counts >= 10) & (ids >= 0))),
                "region_precision": round(float(targets[region].mean()), 3)}

    def near_miss_truth(maps) -> dict:
        """Twenty-seventh session: the near miss of the view handed over as the known product
        (product_memory.near_miss, whether or not the arm leaves it out) against the truth of a frame rendered
        with segmentation now (the loop hands the view over before any motion). nm_cells: its size (0: none);
        nm_on_target: the share of its cells that show a target."""
        from impurity_attention.core.heightmap import rgbd_to_heightmaps
        from impurity_attention.core.product_memory import near_miss
        from impurity_common.grid import HeightmapGrid
        mask = near_miss(maps.color, maps.height, attention, HeightmapGrid())
        if mask is None or not mask.any():
            return {"nm_cells": 0}
        frame = world.render()
        labels = rgbd_to_heightmaps(frame.color, frame.depth, frame.intrinsics, frame.camera_pose,
                                    HeightmapGrid(), labels=frame.segmentation).labels
        targets = np.isin(labels, list(world.ground_truth().target_ids))
        return {"nm_cells": int(mask.sum()), "nm_on_target": round(float(targets[mask].mean()), 3)}

    def targets_at() -> list:
        truth = world.ground_truth()
        return [tuple(round(v, 3) for v in truth.poses[b][0][:2]) for b in truth.target_ids]

    def on_step(step):
        steps.append(step)
        where.append(targets_at())

    verifier = verifier_from_json(rule_params["verifier"]) if "verifier" in rule_params else None
    if "network" in rule_params and "network" not in _WORKER:  # read once per worker
        from impurity_attention.core.impurity_net import read_network
        _WORKER["network"] = read_network(rule_params["network"])
    attention = AttentionParams(verifier_heap_threshold=rule_params.get("verifier_heap_threshold", 0.0),
                                verifier=verifier, impurity_net=_WORKER.get("network"))
    if "verifier_last_look" in rule_params:
        attention = dataclasses.replace(attention, verifier_last_look=rule_params["verifier_last_look"])
    if "stall_look_threshold" in rule_params:
        attention = dataclasses.replace(attention, stall_look_threshold=rule_params["stall_look_threshold"])
    if "near_miss" in rule_params:  # the default since the twenty-seventh session
        attention = dataclasses.replace(attention, known_product_near_miss=rule_params["near_miss"])
    recording = RecordingCell(_WORKER["world"], _WORKER["agent"], attention)
    limits = picking.EpisodeLimits(known_product=rule_params.get("known_product", True),
                                   stall_look_views=rule_params.get("stall_look_views", 5))
    summary = picking.run_episode(recording,
                                  EpisodeRequest(scenario, seed=seed, palette=palette), f"{scenario}-{seed}",
                                  limits, on_step=on_step, on_error=lambda e: (_ for _ in ()).throw(e))
    events, outside = [], 0
    for index, step in enumerate(steps):
        if step.targets_outside > outside:
            x, y, _ = step.position
            end = (x + cell.PUSH_LENGTH * math.cos(step.yaw), y + cell.PUSH_LENGTH * math.sin(step.yaw))
            events.append({"step": step.step, "mode": step.attention_mode, "kind": step.kind,
                           "start_edge": edge_distance(x, y),
                           "end_edge": edge_distance(*end) if step.kind == "push" else None,
                           "new_outside": step.targets_outside - outside, "start": (x, y), "end": end,
                           "targets_before": where[index - 1] if index else None,
                           "targets_after": where[index]})
        outside = step.targets_outside
    grasps = [{"step": step.step, "mode": step.attention_mode, "lifted": step.success,
               "target": step.target_grasped, "target_m": round(decided[index]["target_m"], 4),
               "object_m": round(decided[index]["object_m"], 4), "probability": decided[index]["probability"],
               "last_look": decided[index]["last_look"], "heap": decided[index]["heap"],
               "stall": decided[index]["stall"],
               **{k: decided[index][k] for k in ("mask_precision", "mask_cells", "mask_bodies",
                                                  "region_precision") if k in decided[index]},
               **{k: v for k, v in decided[index].items() if k.startswith("t_")},
               **{k: v for k, v in decided[index].items() if k.startswith("g_")}}
              for index, step in enumerate(steps) if step.kind == "grasp"]
    # thirty-first session: the longest stretch of OCCLUDED_REGION decisions in a row
    run, occluded_run = 0, 0
    for step in steps:
        run = run + 1 if step.attention_mode == "OCCLUDED_REGION" else 0
        occluded_run = max(occluded_run, run)
    return {"scenario": scenario, "seed": seed, "palette": palette, "params": rule_params,
            "occluded_run": occluded_run,
            "termination": summary["termination_reason"], "completed": summary["completed"],
            "picked": summary["targets_picked"], "total": summary["targets_total"],
            "attempts": summary["grasp_attempts"], "actions": summary["actions"],
            "outside": summary["targets_outside"], "events": events, "grasps": grasps,
            **({"near_miss": known} if known else {})}


def run(args) -> None:
    rule_params = {}
    if args.push_end_margin is not None:
        rule_params["push_end_margin"] = args.push_end_margin
    if args.edge_margin is not None:
        rule_params["occluded_push_edge_margin"] = args.edge_margin
    if args.without:
        rule_params["without"] = args.without
    if args.with_rules:
        rule_params["with"] = args.with_rules
    if args.heap_threshold is not None:
        rule_params["verifier_heap_threshold"] = args.heap_threshold
    if args.canonical_colours:
        rule_params["canonical_colours"] = True
    if args.mask_truth:
        rule_params["mask_truth"] = True
    if args.grasp_geometry:
        rule_params["grasp_geometry"] = True
    if args.temporal:
        rule_params["temporal"] = True
    if args.no_known_product:  # the known product is the loop's default since the twenty-sixth session
        rule_params["known_product"] = False
    if args.verifier is not None:
        rule_params["verifier"] = args.verifier
    if args.network is not None:
        rule_params["network"] = args.network
    if args.last_look is not None:
        rule_params["verifier_last_look"] = args.last_look
    if args.stall_look_threshold is not None:
        rule_params["stall_look_threshold"] = args.stall_look_threshold
    if args.near_miss:
        rule_params["near_miss"] = True
    if args.no_near_miss:
        rule_params["near_miss"] = False
    if args.stall is not None:
        rule_params["stall"] = [int(args.stall[0]), float(args.stall[1])]
    if args.no_stall_look:  # the loop's stall look is shipped since the thirty-first session
        rule_params["stall_look_views"] = 0
    names = [args.palette] if args.palette else palettes(args.random_palettes, args.random_from,
                                                         not args.random_only)
    ks = args.only or range(args.start, args.start + args.episodes)
    tasks = [(args.scenario, args.seed_base + k, names[k % len(names)], rule_params) for k in ks]
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    from tqdm import tqdm
    with ProcessPoolExecutor(args.jobs) as pool, open(out, "w") as f:
        for record in tqdm(pool.map(run_one, tasks), total=len(tasks), desc=out.stem):
            f.write(json.dumps(record) + "\n")
            f.flush()


def report(args) -> None:
    for path in args.files:
        rows = [json.loads(line) for line in open(path)]
        attempts = sum(r["attempts"] for r in rows)
        picked = sum(r["picked"] for r in rows)
        events = [e for r in rows for e in r["events"]]
        print(f"{path}: {len(rows)} episodes, params {rows[0]['params'] or 'shipped'}")
        print(f"  grasp success {100 * picked / max(attempts, 1):.1f} %, completion "
              f"{100 * np.mean([r['completed'] for r in rows]):.1f} %, actions/episode "
              f"{np.mean([r['actions'] for r in rows]):.2f}; episodes with a target outside "
              f"{sum(r['outside'] > 0 for r in rows)}")
        terminations = {}
        for r in rows:
            if not r["completed"]:
                terminations[r["termination"]] = terminations.get(r["termination"], 0) + 1
        print("  incomplete by reason:", terminations)
        for e in events:
            end = f"{e['end_edge']:.3f}" if e["end_edge"] is not None else "-"
            print(f"    step {e['step']:2d} {e['mode']:16s} {e['kind']:5s} start {e['start_edge']:.3f} m "
                  f"from the edge, end {end} m")


def grasps(paths: list) -> None:
    """Each file's grasp success (the per-episode mean, as make eval, and pooled) and its failed grasps sorted
    by attention's mode, what was lifted and which body the grasp point lay nearest at decision time."""
    for path in paths:
        rows = [json.loads(line) for line in open(path)]
        rates = [r["picked"] / r["attempts"] for r in rows if r["attempts"]]
        attempts = sum(r["attempts"] for r in rows)
        print(f"{path}: {len(rows)} episodes, palettes {len({r['palette'] for r in rows})}; grasp success "
              f"per-episode mean {100 * np.mean(rates):.1f} % ({len(rates)} episodes with a grasp), pooled "
              f"{100 * sum(r['picked'] for r in rows) / max(attempts, 1):.1f} % ({attempts} attempts); "
              f"completion {100 * np.mean([r['completed'] for r in rows]):.1f} %")
        kinds = {}
        for r in rows:
            for g in r["grasps"]:
                if g["target"]:
                    continue
                nearer = "target" if g["target_m"] < g["object_m"] else "product"
                key = (g["mode"], "product lifted" if g["lifted"] else "nothing lifted", f"nearer a {nearer}")
                kinds.setdefault(key, []).append(min(g["target_m"], g["object_m"]))
        failed = sum(len(v) for v in kinds.values())
        print(f"  failed grasps {failed}:")
        for key, distances in sorted(kinds.items(), key=lambda kv: -len(kv[1])):
            print(f"    {len(distances):4d}  {' / '.join(key)}, median "
                  f"{100 * np.median(distances):.1f} cm from it")
        worst = {}
        for r in rows:
            if r["attempts"]:
                worst.setdefault(r["palette"], []).append(r["picked"] / r["attempts"])
        low = sorted(worst.items(), key=lambda kv: np.mean(kv[1]))[:8]
        print("  lowest palettes:", ", ".join(f"{k} {100 * np.mean(v):.0f} % ({len(v)})" for k, v in low))


FAILED_GRASP_BINS_M = (0.01, 0.02, 0.04)  # the thirty-sixth section's: < 1 / 1-2 / 2-4 / >= 4 cm


def failed_grasps(episodes: list) -> str:
    """A line on the episodes' targets and failed grasps: targets picked of all, failed grasps, how many of
    them lifted a product piece (thrown away with it), and their grasp points' distance to the nearest target
    at decision time (`target_m`) in FAILED_GRASP_BINS_M's bins (>= 4 cm: a grasp at product)."""
    failed = [g for r in episodes for g in r["grasps"] if not g["target"]]
    bins = np.bincount(np.digitize([g["target_m"] for g in failed], FAILED_GRASP_BINS_M), minlength=4)
    return (f"targets picked {sum(r['picked'] for r in episodes)} of {sum(r['total'] for r in episodes)}; "
            f"failed grasps {len(failed)}, product lifted {sum(bool(g['lifted']) for g in failed)}; by "
            f"distance to the nearest target < 1 / 1-2 / 2-4 / >= 4 cm: {' / '.join(map(str, bins))}")


def episodes_by_seed(path: str) -> dict:
    """seed -> episode record of a run file, or of every *.jsonl file of a directory pooled (the scenarios of
    one arm, run on distinct seeds; a seed in two of its files is refused)."""
    where = pathlib.Path(path)
    files = sorted(where.glob("*.jsonl")) if where.is_dir() else [where]
    rows = {}
    for file in files:
        for record in map(json.loads, file.read_text().splitlines()):
            if record["seed"] in rows:
                raise SystemExit(f"{path}: seed {record['seed']} in two files; pool only runs on distinct "
                                 "seeds")
            rows[record["seed"]] = record
    return rows


def paired(base_path: str, other_path: str, draws: int = 5000, fill: bool = False) -> None:
    """The change in grasp success (pooled, and make eval's per-episode mean with an episode without a grasp
    attempt at 0 %) and in completion from base to other on the seeds both ran: point estimates and a paired
    bootstrap's 95 % intervals over the seeds (numpy's default_rng(0)), after each arm's pooled grasp success
    and completion. A directory pools its run files (episodes_by_seed: e.g. one arm's three scenarios).
    fill: a seed only base ran counts as alike in other (a run of --only candidates, where the variant
    cannot act elsewhere; thirty-first session)."""
    base, other = episodes_by_seed(base_path), episodes_by_seed(other_path)
    filled = sorted(set(base) - set(other)) if fill else []
    other.update({s: base[s] for s in filled})
    seeds = np.array(sorted(set(base) & set(other)))

    def per_episode(chosen) -> float:
        rates = [[d[s]["picked"] / d[s]["attempts"] if d[s]["attempts"] else 0.0 for s in chosen]
                 for d in (base, other)]
        return 100 * (np.mean(rates[1]) - np.mean(rates[0]))

    def change(chosen) -> float:
        rate = [sum(d[s]["picked"] for s in chosen) / max(sum(d[s]["attempts"] for s in chosen), 1)
                for d in (base, other)]
        return 100 * (rate[1] - rate[0])

    def completion_change(chosen) -> float:
        return 100 * (np.mean([other[s]["completed"] for s in chosen]) - np.mean([base[s]["completed"]
                                                                                  for s in chosen]))

    rng = np.random.default_rng(0)
    samples = [rng.choice(seeds, len(seeds)) for _ in range(draws)]
    spread = [change(chosen) for chosen in samples]
    completion = np.percentile([completion_change(chosen) for chosen in samples], [2.5, 97.5])
    same = sum(base[s]["actions"] == other[s]["actions"] and base[s]["picked"] == other[s]["picked"]
               and base[s]["attempts"] == other[s]["attempts"] for s in seeds)
    low, high = np.percentile(spread, [2.5, 97.5])
    mean = np.percentile([per_episode(chosen) for chosen in samples], [2.5, 97.5])
    actions = [np.mean([d[s]["actions"] for s in seeds]) for d in (base, other)]
    if filled:
        print(f"{len(filled)} seeds only {base_path} ran, counted alike in {other_path} (--fill)")
    for path, d in ((base_path, base), (other_path, other)):
        pooled = 100 * sum(d[s]["picked"] for s in seeds) / max(sum(d[s]["attempts"] for s in seeds), 1)
        print(f"{path}: grasp success pooled {pooled:.2f} %, completion "
              f"{100 * np.mean([d[s]['completed'] for s in seeds]):.2f} %")
        print(f"   {failed_grasps([d[s] for s in seeds])}")
    print(f"per-episode grasp success (make eval's; no attempt 0 %) change {per_episode(seeds):+.2f} points, "
          f"interval {mean[0]:+.2f} to {mean[1]:+.2f}; actions/episode {actions[0]:.2f} -> {actions[1]:.2f} "
          f"({100 * (actions[1] / actions[0] - 1):+.1f} %)")
    print(f"{other_path} against {base_path}: {len(seeds)} seeds ({same} episodes alike in actions, picks "
          f"and attempts); grasp success change {change(seeds):+.1f} points, paired bootstrap 95 % interval "
          f"{low:+.1f} to {high:+.1f} ({draws} draws); completion change "
          f"{completion_change(seeds):+.1f} points, interval {completion[0]:+.1f} to {completion[1]:+.1f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("scenario")
    r.add_argument("episodes", type=int)
    r.add_argument("out")
    r.add_argument("--push-end-margin", type=float, default=None)
    r.add_argument("--edge-margin", type=float, default=None, help="occluded_push_edge_margin (m)")
    r.add_argument("--without", nargs="*", default=[], help="rules of the cell preset left out")
    r.add_argument("--with", dest="with_rules", nargs="*", default=[],
                   help="rules outside the cell preset added (rules.CANDIDATES), applied in RULE_ORDER")
    r.add_argument("--random-palettes", type=int, default=100)
    r.add_argument("--random-from", type=int, default=RANDOM_FROM, help="first random palette random-<N>")
    r.add_argument("--random-only", action="store_true", help="leave the named tuning palettes out")
    r.add_argument("--stall", nargs=2, type=float, metavar=("K", "T"), default=None,
                   help="after K OCCLUDED_REGION views in a row, attend with verifier_threshold T "
                        "(experiment)")
    r.add_argument("--no-stall-look", action="store_true",
                   help="the cell as shipped before the thirty-first session: no stall look in the loop "
                        "(EpisodeLimits.stall_look_views 0); earlier sessions' --stall runs need it to play "
                        "as they did")
    r.add_argument("--jobs", type=int, default=2)
    r.add_argument("--start", type=int, default=0, help="first episode index k (seed SEED_BASE + k)")
    r.add_argument("--only", type=int, nargs="*", help="these episode indices k only (seed SEED_BASE + k)")
    r.add_argument("--seed-base", type=int, default=SEED_BASE, help="episode k's seed is this + k")
    r.add_argument("--grasp-geometry", action="store_true",
                   help="record the nearest target's pose and contacts at each grasp (grasp_geometry)")
    r.add_argument("--known-product", action="store_true",
                   help="the loop's default since the twenty-sixth session (kept so that earlier commands "
                        "run): the first view without target is the known product (picking.EpisodeLimits)")
    r.add_argument("--near-miss", action="store_true",
                   help="the default since the twenty-seventh session (kept so that its commands run): the "
                        "known product leaves out the region attention would take at the last look's threshold "
                        "in that view (AttentionParams.known_product_near_miss)")
    r.add_argument("--no-near-miss", action="store_true",
                   help="the known product as shipped before the twenty-seventh session: its near miss kept")
    r.add_argument("--no-known-product", action="store_true",
                   help="the cell as shipped before the twenty-sixth session: no known product")
    r.add_argument("--temporal", action="store_true",
                   help="record at each decision what the target mask's cells were in the view before "
                        "(temporal)")
    r.add_argument("--mask-truth", action="store_true",
                   help="record at each grasp how much of attention's target mask shows a target (truth)")
    r.add_argument("--canonical-colours", action="store_true",
                   help="the candidate input rule canonical_colours added, as --with canonical_colours, but "
                        "recorded as the twenty-third session's runs were (params canonical_colours)")
    r.add_argument("--heap-threshold", type=float, default=None,
                   help="attention's verifier_heap_threshold (default: AttentionParams' own, off)")
    r.add_argument("--verifier", default=None,
                   help="attention's region verifier from this JSON (calibrate_attention.py verifier-fit "
                        "--model-json; default: the shipped model)")
    r.add_argument("--network", default=None,
                   help="attention's impurity network from this weights file, for a --verifier that reads "
                        "its features (default: the shipped one; 37th session)")
    r.add_argument("--last-look", type=float, default=None,
                   help="attention's verifier_last_look (default: AttentionParams' own; 21st session)")
    r.add_argument("--stall-look-threshold", type=float, default=None,
                   help="attention's stall_look_threshold (default: AttentionParams' own; 36th session)")
    r.add_argument("--palette", default="",
                   help="this palette for every episode (default: the tuning group's)")
    s = sub.add_parser("report")
    s.add_argument("files", nargs="+")
    g = sub.add_parser("grasps", help="grasp success and the failed grasps sorted (files run with grasps)")
    g.add_argument("files", nargs="+")
    c = sub.add_parser("paired", help="the change in grasp success from BASE to OTHER, paired over seeds "
                                      "(a directory: its run files pooled)")
    c.add_argument("base")
    c.add_argument("other")
    c.add_argument("--fill", action="store_true",
                   help="a seed only BASE ran counts as alike in OTHER (OTHER run with --only candidates)")
    k = sub.add_parser("candidates", help="the episode indices k (seed - SEED_BASE) of FILE's episodes with "
                                          "K or more OCCLUDED_REGION decisions in a row, for run --only")
    k.add_argument("file")
    k.add_argument("k", type=int)
    k.add_argument("--seed-base", type=int, default=SEED_BASE)
    args = p.parse_args(argv)
    if args.command == "run":
        run(args)
    elif args.command == "report":
        report(args)
    elif args.command == "grasps":
        grasps(args.files)
    elif args.command == "paired":
        paired(args.base, args.other, fill=args.fill)
    elif args.command == "candidates":
        rows = [json.loads(line) for line in open(args.file)]
        print(" ".join(str(r["seed"] - args.seed_base) for r in rows if r["occluded_run"] >= args.k))
    return 0


if __name__ == "__main__":
    sys.exit(main())
