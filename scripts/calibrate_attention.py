#!/usr/bin/env python3
"""Calibrate the attention module on sim-rendered scenes and measure the issue-4 acceptance figures.

    python scripts/calibrate_attention.py collect --split tuning      # render + cache tuning scenes
    python scripts/calibrate_attention.py sweep                       # saliency / DBSCAN choices on them
    python scripts/calibrate_attention.py evaluate --split acceptance # the acceptance table (new seeds)
    python scripts/calibrate_attention.py gallery                     # docs/images/attention_*.png
    python scripts/calibrate_attention.py lab-reference               # colour-adaptation reference
    python scripts/calibrate_attention.py palette-evaluate            # held-out palettes + exposure x0.5, x2
    python scripts/calibrate_attention.py palette-gallery             # docs/images/palettes.png
    python scripts/calibrate_attention.py network-fit                 # the impurity network (tuning)
    python scripts/calibrate_attention.py verifier-fit                # the region verifier (tuning)

Tuning seeds (0..99) and acceptance seeds (1000..) never overlap. Palettes (issue 17) follow the split
of impurity_learning/splits.py: the relative threshold is chosen on tuning palettes with tuning seeds
only; held-out palettes are rendered on evaluation seeds, each palette on scenes of its own
(splits.HELD_OUT_LAYOUT_SEED_BASE; the retired sets on acceptance seeds), and only measured. Rendered
scenes are cached as .npz under runs/perception/ (rendering and settling is the slow part); `evaluate`
collects what is missing.
Everything is seeded: the same command gives the same figures.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import pathlib
import sys
import time

import numpy as np

from impurity_attention.core import evaluation
from impurity_attention.core.attention import (
    AttentionParams,
    attend,
    saliency_input,
    salient_regions,
)
from impurity_attention.core.density import DensityParams, find_clusters, select_occluded_region
from impurity_attention.core.saliency import VOCUS2_CLUTTER, VOCUS2_DEFAULTS, SaliencyParams, vocus2

ROOT = pathlib.Path(__file__).resolve().parents[1]
CACHE = ROOT / "runs" / "perception"
IMAGES = ROOT / "docs" / "images"
SEED_BASE = {"tuning": 0, "acceptance": 1000}
NUM_OBJECTS = 20
# (scenario, num_targets, scenes in tuning, scenes in acceptance)
PLAN = [
    ("random", 2, 20, 30),
    ("challenging", 2, 12, 30),
    ("random", 0, 10, 15),
    ("challenging", 0, 6, 10),
    ("invisible", 0, 4, 8),  # heaps without an impurity inside
    ("invisible", 2, 12, 30),  # two heaps, one target under each (the scenario's default)
    ("invisible", 1, 6, 15),  # two heaps, one of them empty: the harder choice
]


def scene_list(split: str) -> list:
    scenes = []
    for index, (scenario, targets, tuning, acceptance) in enumerate(PLAN):
        count = tuning if split == "tuning" else acceptance
        base = SEED_BASE[split] + 100 * index
        scenes += [(scenario, base + i, targets, NUM_OBJECTS) for i in range(count)]
    return scenes


def patch_prism_winding() -> bool:
    """Workaround for a simulator defect (reported, not fixed here): ur5_driver_sim's prism mesh has
    its triangles wound inward, so the renderer culls the outside and the camera sees the prism's
    inside - table-level depth and a darkened colour. When (and only when) the mesh is inward, reverse
    its winding in this process. Returns whether it patched."""
    from ur5_driver_sim.core import shapes

    vertices, indices = shapes._prism_mesh((0.045, 0.05, 0.035))
    points = np.array(vertices)
    centre = points.mean(axis=0)
    outward = 0.0
    for t in range(0, len(indices), 3):
        a, b, c = points[indices[t]], points[indices[t + 1]], points[indices[t + 2]]
        outward += np.sign(np.cross(b - a, c - a) @ ((a + b + c) / 3 - centre))
    if outward >= 0:
        return False
    original = shapes._prism_mesh

    def outward_prism(dims):
        mesh_vertices, mesh_indices = original(dims)
        flipped = [i for t in range(0, len(mesh_indices), 3)
                   for i in (mesh_indices[t], mesh_indices[t + 2], mesh_indices[t + 1])]
        return mesh_vertices, flipped

    shapes._prism_mesh = outward_prism
    return True


def collect(split: str, limit: int | None = None, cache_suffix: str = "", depth_noise: float = 0.0) -> list:
    path = CACHE / f"{split}{cache_suffix}.npz"
    wanted = scene_list(split)[:limit] if limit else scene_list(split)
    cached = {}
    if path.exists():
        cached = {(r.scenario, r.seed, r.num_targets): r for r in evaluation.load_records(path)}
    missing = [s for s in wanted if (s[0], s[1], s[2]) not in cached]
    if missing:
        from ur5_driver_sim.core.world import CellWorld
        world = CellWorld(mode="floating", depth_noise_std=depth_noise)
        started = time.perf_counter()
        for i, (scenario, seed, targets, objects) in enumerate(missing):
            try:
                record = evaluation.record_from_world(world, scenario, seed, targets, objects)
            except RuntimeError as error:  # the sim could not build the scene: report, skip
                print(f"  skipped {scenario} seed {seed}: {error}", file=sys.stderr)
                continue
            cached[(scenario, seed, targets)] = record
            if (i + 1) % 10 == 0:
                print(f"  rendered {i + 1}/{len(missing)} scenes ({time.perf_counter() - started:.0f} s)")
        world.close()
        CACHE.mkdir(parents=True, exist_ok=True)
        evaluation.save_records(path, list(cached.values()))
    return [cached[(s[0], s[1], s[2])] for s in wanted if (s[0], s[1], s[2]) in cached]


def evaluate(records, params: AttentionParams, verbose: bool = False) -> tuple:
    verdicts, times = [], []
    for record in records:
        started = time.perf_counter()
        output = attend(record.color, record.height, params)
        times.append((time.perf_counter() - started) * 1000)
        verdict = evaluation.judge(record, output)
        verdicts.append(verdict)
        if verbose and not verdict.success:
            print(f"  miss: {verdict.scenario:11s} seed {verdict.seed:5d} {verdict.category:11s} "
                  f"{verdict.mode:15s} score {verdict.score:.4f}  {verdict.detail}")
    return verdicts, np.array(times)


def print_summary(verdicts, times=None) -> dict:
    summary = evaluation.summarize(verdicts)
    aims = {"visible": ("target found", ">= 95 %"), "no_impurity": ("not TARGET", "TARGET <= 5 %"),
            "invisible": ("cluster holds a hidden target", ">= 80 %")}
    for category, entry in summary.items():
        what, aim = aims[category]
        print(f"{category:12s} {entry['scenes']:4d} scenes  {what}: {entry['successes']}/{entry['scenes']} = "
              f"{100 * entry['rate']:.1f} %  (aim {aim})  modes {entry['modes']}")
        if "mask_precision_mean" in entry:
            print(f"{'':12s} target mask on targets: mean {100 * entry['mask_precision_mean']:.1f} %, "
                  f"worst {100 * entry['mask_precision_min']:.1f} %")
    groups = {}
    for v in verdicts:
        groups.setdefault((v.scenario, v.category), []).append(v.success)
    for (scenario, category), results in sorted(groups.items()):
        print(f"    {scenario:11s} {category:11s} {sum(results)}/{len(results)}")
    excluded = sum(v.category == "excluded" for v in verdicts)
    if excluded:
        print(f"    ({excluded} random/challenging scenes with every target hidden were not judged)")
    if times is not None and len(times):
        print(f"attention latency over these scenes: p50 {np.percentile(times, 50):.1f} ms, "
              f"p95 {np.percentile(times, 95):.1f} ms")
    return summary


def best_region_scores(records, params: AttentionParams) -> list:
    """Per scene: (category, best region score, best region on a target?) - thresholds can then be
    tried without recomputing saliency."""
    rows = []
    for record in records:
        objects = record.height > params.density.occupied_height
        image = saliency_input(record.color, objects)
        regions = salient_regions(vocus2(image, params.saliency).saliency, objects, params)
        best = regions[0] if regions else None
        on_target = best is not None and bool(np.any(best.mask & record.visible_target_cells))
        rows.append((record.category(), best.score if best else 0.0, on_target))
    return rows


def sweep(records) -> None:
    print("== saliency: best-region contrast, visible-target scenes vs scenes without impurity")
    settings = (("VOCUS2 defaults (3, 13)", VOCUS2_DEFAULTS), ("VOCUS2 clutter (2, 6)", VOCUS2_CLUTTER),
                ("(2, 10, stop 3)", SaliencyParams(2.0, 10.0, 2, 0, 3)))
    for name, saliency in settings:
        for _ in (0,):
            params = AttentionParams(saliency=saliency)
            rows = best_region_scores(records, params)
            visible = np.array([(s, t) for c, s, t in rows if c == "visible"])
            clean = np.array([s for c, s, _ in rows if c == "no_impurity"])
            on_target = visible[:, 1].astype(bool)
            best_threshold, best_rate = None, -1.0
            for threshold in np.linspace(0.01, 0.15, 141):
                false_alarms = float(np.mean(clean >= threshold))
                rate = float(np.mean(on_target & (visible[:, 0] >= threshold)))
                if false_alarms <= 0.0 and rate > best_rate:
                    best_threshold, best_rate = threshold, rate
            print(f"{name:24s}: best region on a target in "
                  f"{on_target.mean() * 100:5.1f} % of {len(visible)} visible scenes; contrast on target "
                  f"min {visible[on_target, 0].min():.4f} "
                  f"p10 {np.percentile(visible[on_target, 0], 10):.4f}; "
                  f"no-impurity max {clean.max():.4f} p90 {np.percentile(clean, 90):.4f}; lowest threshold "
                  f"with no false alarm {best_threshold:.3f} -> found {best_rate * 100:.1f} %")
    print("== DBSCAN on invisible scenes (and no-impurity heaps): chosen cluster holds a hidden target")
    hidden = [r for r in records if r.category() == "invisible"]
    for score in ("volume",):
        # (stride, eps, min_samples): min_samples must stay below the grid points within eps
        for stride, eps, min_samples in ((2, 0.012, 18), (3, 0.015, 12), (2, 0.016, 30), (4, 0.016, 8)):
            for min_height in (0.03, 0.045):
                density = DensityParams(stride=stride, eps=eps, min_samples=min_samples,
                                        min_cluster_height=min_height)
                hits = 0
                for record in hidden:
                    chosen = select_occluded_region(find_clusters(record.height, 0.002, density))
                    hits += chosen is not None and any(chosen.mask[r, c] for r, c in record.target_cells
                                                       if 0 <= r < 224 and 0 <= c < 224)
                print(f"  score={score:6s} stride={stride} eps={eps:.3f} min_samples={min_samples:2d} "
                      f"min_height={min_height:.3f}: {hits}/{len(hidden)}")


def gallery(params: AttentionParams) -> None:
    """PNG pictures for the README: camera image, colour heightmap, saliency, choice and crops; and a
    DBSCAN example on an invisible scene."""
    import cv2

    from impurity_attention.core.attention import debug_image
    from impurity_attention.core.saliency import normalised
    from ur5_driver_sim.core.world import CellWorld

    IMAGES.mkdir(parents=True, exist_ok=True)
    world = CellWorld(mode="floating")

    def tile(image, label):
        if image.shape[:2] != (224, 224):
            image = cv2.resize(image, (224, 224), interpolation=cv2.INTER_NEAREST)
        image = image.copy()
        cv2.putText(image, label, (4, 218), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
        return image

    def crop_tile(output):
        canvas = np.zeros((224, 224, 3), np.uint8)
        canvas[:112, 56:168] = output.color_crop
        canvas[112:, 56:168] = output.mask[..., None]
        return canvas

    def heat(values):
        colored = cv2.applyColorMap((normalised(values) * 255).astype(np.uint8), cv2.COLORMAP_JET)
        return cv2.cvtColor(colored, cv2.COLOR_BGR2RGB)

    rows = []
    for scenario, seed, targets in (("random", 1001, 2), ("challenging", 1102, 2), ("random", 1201, 0)):
        record, frame = evaluation.record_from_world(world, scenario, seed, targets, NUM_OBJECTS,
                                                     keep_frame=True)
        output = attend(record.color, record.height, params)
        camera = cv2.resize(frame.color, (298, 224), interpolation=cv2.INTER_AREA)[:, 37:261]
        rows.append(np.concatenate([
            tile(camera, f"camera ({scenario}, {targets} targets)"), tile(record.color, "colour heightmap"),
            tile(heat(output.saliency), "VOCUS2 saliency"), tile(debug_image(record.color, output),
                                                                 f"{output.mode.name} {output.score:.3f}"),
            tile(crop_tile(output), "crop + mask (112 px)")], axis=1))
    picture = np.concatenate(rows, axis=0)
    cv2.imwrite(str(IMAGES / "attention_saliency.png"), cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))

    record, frame = evaluation.record_from_world(world, "invisible", 1515, 2, NUM_OBJECTS, keep_frame=True)
    output = attend(record.color, record.height, params)
    clusters = find_clusters(record.height, 0.002, params.density)
    palette = np.random.default_rng(0).integers(60, 255, (len(clusters) + 1, 3)).astype(np.uint8)
    labels = np.zeros_like(record.color)
    for i, cluster in enumerate(clusters):  # clusters too low or small to hide anything: grey
        labels[cluster.mask] = palette[i] if cluster.passes else (90, 90, 90)
    if output.cluster is not None:
        contours, _ = cv2.findContours(output.cluster.mask.astype(np.uint8), cv2.RETR_EXTERNAL,
                                       cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(labels, contours, -1, (255, 255, 255), 2)
    for r, c in record.target_cells:
        cv2.drawMarker(labels, (int(c), int(r)), (255, 0, 0), cv2.MARKER_CROSS, 12, 2)
    height_grey = (np.clip(record.height / 0.1, 0, 1) * 255).astype(np.uint8)
    height_image = cv2.cvtColor(height_grey, cv2.COLOR_GRAY2RGB)
    camera = cv2.resize(frame.color, (298, 224), interpolation=cv2.INTER_AREA)[:, 37:261]
    picture = np.concatenate([
        tile(camera, "camera (invisible)"), tile(height_image, "height 0-10 cm"),
        tile(labels, "clusters; + hidden target"),
        tile(debug_image(record.color, output), output.mode.name),
        tile(crop_tile(output), "crop + all-one mask")], axis=1)
    cv2.imwrite(str(IMAGES / "attention_dbscan.png"), cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))
    world.close()
    print(f"wrote {IMAGES / 'attention_saliency.png'} and {IMAGES / 'attention_dbscan.png'}")


# Scenes per palette (scenario, targets, count): a fifth of PLAN's tuning counts, same seed layout.
PALETTE_PLAN = [("random", 2, 6), ("challenging", 2, 4), ("random", 0, 3), ("challenging", 0, 2),
                ("invisible", 0, 1), ("invisible", 2, 2), ("invisible", 1, 1)]
PALETTE_RANDOM_COUNT = {"tuning": 96}  # random tuning palettes (held-out and retired: splits.py's counts)
EXPOSURES = (0.5, 1.0, 2.0)
TARGET_FOUND_AIM, FALSE_TARGET_AIM = 0.95, 0.05


def palette_names(split: str) -> list:
    from impurity_learning import splits

    if split == "tuning":
        return splits.tuning_palettes(PALETTE_RANDOM_COUNT["tuning"])
    if split == "retired":  # the earlier held-out sets (splits.RETIRED_SETS), measured for comparison
        return splits.retired_palettes()
    return splits.held_out_palettes()


OWN_LAYOUT_SEED_BASE = 20_000  # collect_palettes(own_layouts=True): tuning seeds of no other use (splits.py)
# The default palette's exposure scenes (eleventh session): (scenario, targets, scenes) on seeds base +
# 1000 x row + i, tuning seeds of no other use. verifier_fit(exposure_scenes=True) learns from
# EXPOSURE_FIT_SEED_BASE's at every EXPOSURE (tried, not kept); docs/experiments_s11/exposure_wide.py checks
# on EXPOSURE_CHECK_SEED_BASE's (and on 40000+, a second check set), which nothing is fitted on.
EXPOSURE_PLAN = [("random", 0, 60), ("challenging", 0, 60), ("invisible", 0, 30), ("random", 2, 30),
                 ("challenging", 2, 30)]
EXPOSURE_FIT_SEED_BASE, EXPOSURE_CHECK_SEED_BASE = 35_000, 30_000
# network-fit's further views (tuning seeds of no other use, splits.TUNING_SEED_BLOCKS): random-800 ... 999 on
# layouts of their own (PALETTE_PLAN's rows packed) and the default palette's EXPOSURE_PLAN at twice its
# counts (rows packed)
NETWORK_PALETTES = [f"random-{800 + k}" for k in range(200)]
NETWORK_PALETTE_SEED_BASE, NETWORK_DEFAULT_SEED_BASE = 26_200, 76_200
NETWORK_EPOCHS = 6
NETWORK_OUT = ROOT / "runs" / "impurity_net.pt"  # network-fit without --write-network


def collect_exposure_scenes(seed_base: int = EXPOSURE_FIT_SEED_BASE, count_scale: float = 1.0,
                            packed: bool = False, cache: str | None = None) -> list:
    """The default palette's EXPOSURE_PLAN scenes on seeds seed_base + 1000 x row + i (at exposure x1; callers
    expose them), cached in runs/perception/exposure_<seed_base>.npz (or `cache`); count_scale scales every
    row's count. packed: the rows one after the other instead, seeds seed_base + i (exposure_<seed_base>
    _packed.npz), for a stretch of free tuning seeds shorter than 1000 x the rows."""
    counts = [int(count * count_scale) for *_, count in EXPOSURE_PLAN]
    starts = np.concatenate([[0], np.cumsum(counts)]) if packed else 1000 * np.arange(len(counts))
    wanted = [("", scenario, seed_base + int(starts[row]) + i, targets)
              for row, ((scenario, targets, _), count) in enumerate(zip(EXPOSURE_PLAN, counts, strict=True))
              for i in range(count)]
    cache = cache or f"exposure_{seed_base}{'_packed' if packed else ''}.npz"
    return render_cached(CACHE / cache, wanted, f"exposure scenes {seed_base}+")


def collect_palettes(split: str, scale: int = 1, own_layouts: bool = False) -> list:
    """Records of every palette of the split (cached in runs/perception/palettes_<split>.npz). Tuning
    palettes share the same scene seeds (tuning seeds), as do the retired held-out sets (acceptance seeds;
    records are keyed by palette). The held-out set ("acceptance") gives each palette scenes of its own, on
    evaluation seeds splits.held_out_layout_seed(row, the palette's index, the row's count) + i (cached in
    palettes_held_out_own.npz; the sets before the eighth shared the ten layouts of the acceptance seeds).
    own_layouts (tuning only): every palette gets scenes of its own, seeds OWN_LAYOUT_SEED_BASE + 1000 x
    the plan's row + the palette's index x the row's count + i, so that a choice made over palettes is not
    made on ten layouts only (cached in palettes_tuning_own.npz)."""
    from impurity_learning import splits

    palettes = palette_names(split)
    if own_layouts and split != "tuning":
        raise ValueError("own_layouts is for tuning palettes (the held-out set always has scenes of its own)")
    held_out = split == "acceptance"  # from the eighth set on: scenes of its own per palette (splits.py)
    split = "acceptance" if split == "retired" else split
    suffix = ('' if scale == 1 else f'_x{scale}') + ('_own' if own_layouts or held_out else '')
    path = CACHE / f"palettes_{'held_out' if held_out else split}{suffix}.npz"
    if own_layouts:
        def base(row, number, count):
            return OWN_LAYOUT_SEED_BASE + 1000 * row + number * count
    elif held_out:
        base = splits.held_out_layout_seed
    else:
        def base(row, number, count):
            return SEED_BASE[split] + 100 * row
    return render_cached(path, palette_scenes(palettes, base, scale), f"{'held-out' if held_out else split} "
                                                                      "palettes")


def network_palette_records(palettes: list | None = None, cache: str = "palettes_train800_own.npz") -> list:
    """NETWORK_PALETTES (or `palettes`, as many, e.g. the same with a product jitter suffix) on layouts of
    their own: PALETTE_PLAN's rows packed one after the other, seeds NETWORK_PALETTE_SEED_BASE + the row's
    offset + palette index x the row's count + i (26 200 ... 29 999); cached in CACHE / `cache`."""
    palettes = palettes or NETWORK_PALETTES
    assert len(palettes) == len(NETWORK_PALETTES)  # the registered block holds this many
    wanted = palette_scenes(palettes, packed_layouts(NETWORK_PALETTE_SEED_BASE, len(palettes)))
    assert max(seed for *_, seed, _ in wanted) < 30_000  # the registered block
    return render_cached(CACHE / cache, wanted, f"network training palettes ({cache})")


def network_default_records() -> list:
    """The default palette's EXPOSURE_PLAN at twice its counts (420 scenes), the rows packed one after the
    other on seeds NETWORK_DEFAULT_SEED_BASE + i (76 200 ... 76 619), at exposure x1; cached in
    default_train76200.npz."""
    return collect_exposure_scenes(NETWORK_DEFAULT_SEED_BASE, 2, packed=True,
                                   cache=f"default_train{NETWORK_DEFAULT_SEED_BASE}.npz")


def network_records(invisible: bool = True) -> list:
    """The impurity network's training views (network-fit; H4 of the thirty-fourth session, docs/
    experiments.md): rule-sweep's scenes (the default palette's also at x0.5 and x2), the tuning palettes'
    own-layout scenes, network_palette_records() and network_default_records(); only scenes of
    evaluation.CATEGORIES, and with invisible False none of the invisible layout (H5: their impurities are
    always cubes)."""
    records = (rule_sweep_records()[0] + collect_palettes("tuning", own_layouts=True)
               + network_palette_records() + network_default_records())
    return [r for r in records if r.category() in evaluation.CATEGORIES and (invisible or
                                                                            r.scenario != "invisible")]


def network_fit(params: AttentionParams, epochs: int, out: pathlib.Path, invisible: bool = True,
                positive_weight: float | None = None) -> None:
    """Train the impurity network (impurity_learning.impurity_net_training) on network_records(invisible) and
    write it to `out` (impurity_net.write_network), with its provenance; prints each epoch's mean loss.
    positive_weight: an impurity cell's weight in the loss (None: impurity_net_training.POSITIVE_WEIGHT)."""
    import torch

    from impurity_attention.core.attention import sanitize
    from impurity_attention.core.impurity_net import write_network
    from impurity_learning import splits
    from impurity_learning.impurity_net_training import POSITIVE_WEIGHT, train_impurity_net

    torch.set_num_threads(max(1, min(4, torch.get_num_threads())))
    records = network_records(invisible)
    views = []
    for record in records:
        color, height = sanitize(record.color, record.height)
        views.append((color, height, height > params.density.occupied_height, record.visible_target_cells))
    palettes = len({r.palette or "blocks" for r in records})
    weight = POSITIVE_WEIGHT if positive_weight is None else positive_weight
    net, losses = train_impurity_net(views, epochs, exposure=splits.TRAINING_EXPOSURE, positive_weight=weight)
    options = ('' if invisible else ' --no-invisible') + ('' if positive_weight is None
                                                         else f' --positive-weight {positive_weight:g}')
    provenance = (f"scripts/calibrate_attention.py network-fit{options}: "
                  f"{len(views)} tuning views of {palettes} palettes, {epochs} epochs, exposure drawn in "
                  f"{splits.TRAINING_EXPOSURE}; mean loss {losses[0]:.4f} -> {losses[-1]:.4f}")
    write_network(net, out, provenance)
    print(f"wrote {out}: {provenance}")


def packed_layouts(seed_base: int, palette_count: int):
    """A palette_scenes base giving `palette_count` palettes layouts of their own with PALETTE_PLAN's rows
    packed one after the other from seed_base: row r starts after every palette's scenes of rows < r, and a
    palette's scenes of a row follow the previous palette's (palette_count x 19 seeds in all)."""
    offsets = np.concatenate([[0], np.cumsum([palette_count * count for *_, count in PALETTE_PLAN])])
    return lambda row, number, scenes: seed_base + int(offsets[row]) + number * scenes


def palette_scenes(palettes: list, base, scale: int = 1) -> list:
    """The scenes PALETTE_PLAN asks of each palette, as render_cached wants them: (palette, scenario, seed,
    targets) for every palette, plan row and i < the row's count x scale, on seeds base(row, the palette's
    index, the row's count x scale) + i (a base ignoring the palette's index gives every palette the same
    layouts)."""
    return [(palette, scenario, base(row, number, count * scale) + i, targets)
            for number, palette in enumerate(palettes)
            for row, (scenario, targets, count) in enumerate(PALETTE_PLAN) for i in range(count * scale)]


def render_cached(path: pathlib.Path, wanted: list, what: str) -> list:
    """Records of `wanted` ((palette, scenario, seed, num_targets), palette "" the default) in that order:
    those cached in `path` (.npz), the others rendered (a scene the sim cannot build is reported and
    skipped) and the cache rewritten with them."""
    cached = {}
    if path.exists():
        cached = {(r.palette, r.scenario, r.seed, r.num_targets): r for r in evaluation.load_records(path)}
    missing = [w for w in wanted if w not in cached]
    if missing:
        from tqdm import tqdm

        from ur5_driver_sim.core.world import CellWorld

        world = CellWorld(mode="floating")
        for palette, scenario, seed, targets in tqdm(missing, desc=f"render {what}", unit="scene"):
            try:
                record = evaluation.record_from_world(world, scenario, seed, targets, NUM_OBJECTS,
                                                      palette=palette)
            except RuntimeError as error:
                print(f"  skipped {palette} {scenario} seed {seed}: {error}", file=sys.stderr)
                continue
            cached[(palette, scenario, seed, targets)] = record
        world.close()
        CACHE.mkdir(parents=True, exist_ok=True)
        evaluation.save_records(path, list(cached.values()))
    return [cached[w] for w in wanted if w in cached]


def palette_rates(records, params: AttentionParams) -> dict:
    """Per palette: visible scenes with the impurity found, scenes without impurity given TARGET, invisible
    scenes with the hidden target in the chosen cluster, and visible scenes whose impurity is
    colour-separable (evaluation.colour_separable, read from the truth: what "found" is read against)."""
    rates = {}
    for record in records:
        verdict = evaluation.judge(record, attend(record.color, record.height, params))
        entry = rates.setdefault(record.palette, {"visible": [], "no_impurity": [], "invisible": [],
                                                  "separable": []})
        if verdict.category in entry:
            entry[verdict.category].append(bool(verdict.success))
        if verdict.category == "visible":
            entry["separable"].append(bool(evaluation.colour_separable(record)))
    return rates


def aim_word(share: float, met: bool) -> str:
    """'met', 'NOT met', or 'no scenes' when the share is NaN (nothing counted)."""
    return "no scenes" if np.isnan(share) else "met" if met else "NOT met"


def print_palette_rates(rates: dict, per_palette: bool = True) -> dict:
    """Print a line per palette (unless per_palette is False) and the totals; return the totals."""
    totals = {"visible": [], "no_impurity": [], "invisible": [], "separable": []}
    for palette, entry in rates.items():
        for key in totals:
            totals[key] += entry.get(key, [])
        if per_palette:
            print(f"  {palette:22s} impurity found {sum(entry['visible']):3d}/{len(entry['visible']):3d}  "
                  f"false TARGET {len(entry['no_impurity']) - sum(entry['no_impurity']):2d}/"
                  f"{len(entry['no_impurity']):2d}  hidden target in chosen cluster "
                  f"{sum(entry['invisible'])}/{len(entry['invisible'])}  colour-separable "
                  f"{sum(entry.get('separable', []))}/{len(entry.get('separable', []))}")
    found = float(np.mean(totals["visible"])) if totals["visible"] else float("nan")
    false = 1.0 - float(np.mean(totals["no_impurity"])) if totals["no_impurity"] else float("nan")
    hidden = float(np.mean(totals["invisible"])) if totals["invisible"] else float("nan")
    separable = float(np.mean(totals["separable"])) if totals["separable"] else float("nan")
    # counts and a two-decimal share: 1899/2000 is 94.95 %, which one decimal would print as a met 95.0 %
    n_found, n_false = sum(totals["visible"]), len(totals["no_impurity"]) - sum(totals["no_impurity"])
    visible, clean = len(totals["visible"]), len(totals["no_impurity"])  # the aims judged on whole counts
    found_aim = aim_word(found, 100 * n_found >= 95 * visible)
    false_aim = aim_word(false, 100 * n_false <= 5 * clean)
    print(f"  ALL: impurity found {n_found}/{len(totals['visible'])} = {100 * found:.2f} % "
          f"(aim >= 95 %: {found_aim}), false TARGET {n_false}/{len(totals['no_impurity'])} = "
          f"{100 * false:.2f} % (aim <= 5 %: {false_aim}), hidden target in chosen cluster "
          f"{sum(totals['invisible'])}/{len(totals['invisible'])} = {100 * hidden:.1f} %, colour-separable "
          f"{100 * separable:.1f} % (evaluation.colour_separable: a per-cell oracle tells it by colour)")
    return {"found": found, "false_target": false, "hidden_in_cluster": hidden,
            "colour_separable": separable, "visible_scenes": len(totals["visible"]),
            "clean_scenes": len(totals["no_impurity"])}


def rule_sweep_records(exposed: bool = True) -> tuple:
    """rule-sweep's scenes: (records, the default palette's records at exposure x1). The tuning palettes'
    scenes and the default palette's own tuning scenes (seeds 0-99: the first calibration's; the palette
    the cell ships with, and more of its heaps, where product blocks in shadow must not read as targets),
    with exposed the default's also at the other EXPOSURES (x0.5, x2)."""
    records = collect_palettes("tuning")
    have = {(r.scenario, r.seed, r.num_targets) for r in records if r.palette == "blocks"}
    records += [r for r in collect("tuning") if (r.scenario, r.seed, r.num_targets) not in have]
    default = [r for r in records if r.palette in ("blocks", "")]
    if exposed:
        records = records + [r.exposed(e) for r in default for e in EXPOSURES if e != 1.0]
    return records, default


VERIFIER_FOLDS = 5  # verifier-fit: palette-grouped cross-validation folds
VERIFIER_FALSE_TARGET = 0.01  # verifier-fit: the threshold allows this share of false TARGETs (tuning scenes)


def verifier_rows(records, params: AttentionParams, network=None) -> tuple:
    """The region verifier's training rows: per scene without a visible impurity or with one (category
    visible, no_impurity, invisible), its best salient regions' features as attention scores them
    (verifier.candidate_features; network: the impurity network for NETWORK_FEATURES, else they are NaN).
    Returns (features (N, F), on target (N,) bool, scene index (N,), group
    (N,): the palette, visible per scene (S,) bool); a scene without a salient region has no row."""
    from impurity_attention.core.attention import scene_maps
    from impurity_attention.core.verifier import candidate_features
    rows, on, scene, group, visible = [], [], [], [], []
    for record in records:
        category = record.category()
        if category not in evaluation.CATEGORIES:
            continue
        index = len(visible)
        visible.append(category == "visible")
        objects = record.height > params.density.occupied_height
        saliency, conspicuity = scene_maps(record.color, objects, params)
        regions = salient_regions(saliency, objects, params)
        for region, row in candidate_features(record.color, record.height, objects, conspicuity, regions,
                                              network=network):
            if row is None:  # every object in view: attention lets saliency decide (no features)
                continue
            rows.append(row)
            on.append(category == "visible" and bool(np.any(region.mask & record.visible_target_cells)))
            scene.append(index)
            group.append(record.palette or "blocks")
    return (np.array(rows), np.array(on, bool), np.array(scene), np.array(group), np.array(visible, bool))


def scene_decisions(probability, on, scene, count) -> tuple:
    """Per scene (count scenes): the highest region probability (-1 without a region) and whether that
    region lies on the impurity: what attend() with decision "verifier" decides from."""
    best = np.full(count, -1.0)
    hit = np.zeros(count, bool)
    for p, o, s in zip(probability, on, scene, strict=True):
        if p > best[s]:
            best[s], hit[s] = p, o
    return best, hit


def threshold_at(best, visible, cap: float) -> float:
    """The least threshold (just above a clean scene's probability) that lets at most `cap` of the scenes
    without a visible impurity through."""
    return threshold_letting_through(best, visible, int(np.floor(cap * np.sum(~visible))))


def threshold_letting_through(best, visible, allowed: int) -> float:
    """The least threshold (just above a clean scene's probability) that lets at most `allowed` of the scenes
    without a visible impurity through (0.0 when there are no more than `allowed` of them)."""
    clean = np.sort(best[~visible])[::-1]
    return float(np.nextafter(clean[allowed], 1.0)) if allowed < len(clean) else 0.0


def verifier_fit(params: AttentionParams, write: bool, own_layouts: bool = False, check: bool = True,
                 exposure_scenes: bool = False, loop_views: tuple = (),
                 model_json: pathlib.Path | None = None, threshold_on: str = "all",
                 feature_names: tuple | None = None, network=None):
    """The region verifier (impurity_attention.core.verifier) fitted on rule-sweep's tuning scenes only:
    logistic regression (scikit-learn, standardised features, C = 1) of "this region lies on the impurity"
    on the TOP_REGIONS best regions of every scene. Judged first by palette-grouped cross-validation
    (VERIFIER_FOLDS folds; each fold's palettes unseen by its model, as held-out palettes are), with the
    threshold taken (a) on the out-of-fold probabilities and (b) on the training folds' own (nested: what an
    unseen palette gets). Then fitted on all the scenes, its threshold the least that lets through
    VERIFIER_FALSE_TARGET of the scenes without a visible impurity; written to checkpoints/verifier.json with
    --write-model, and checked through attend(). own_layouts: the tuning palettes' own-layout scenes
    (collect_palettes(own_layouts=True)) join rule-sweep's, and the check is printed for each half (check:
    whether to run it). exposure_scenes: the default palette's exposure scenes (collect_exposure_scenes) at
    every EXPOSURE join them (tried in the eleventh session and not kept: docs/experiments.md; the shipped
    model is fitted without). loop_views: .npz files of picking-loop views (scene records, e.g.
    docs/experiments_s17/loop_views.py collect) join them as a half of their own. model_json: the fitted
    model is also written there as JSON (RegionVerifier's fields). threshold_on: "all" scenes and views, or
    "first-views" (the loop views left out of the threshold's count). feature_names: the model's features, a
    subset of verifier.ALL_FEATURES (default ALL_FEATURES with a network, else FEATURES). network:
    the impurity network (impurity_net.ImpurityNet) the rows' NETWORK_FEATURES read. Returns the fitted
    RegionVerifier."""
    from sklearn.linear_model import LogisticRegression
    from sklearn.model_selection import GroupKFold
    from sklearn.preprocessing import StandardScaler

    from impurity_attention.core.verifier import (
        ALL_FEATURES,
        FEATURES,
        SOURCE_VERIFIER,
        RegionVerifier,
        default_verifier,
        write_verifier,
    )

    shipped = default_verifier()
    unknown = sorted(set(feature_names or ()) - set(ALL_FEATURES))
    if unknown:
        raise SystemExit(f"verifier-fit: unknown features {', '.join(unknown)}; known: "
                         f"{', '.join(ALL_FEATURES)}")
    if network is None and set(feature_names or ()) - set(FEATURES):
        raise SystemExit(f"verifier-fit: {', '.join(sorted(set(feature_names) - set(FEATURES)))} need the "
                         "impurity network: give --network (shipped, or a weights file)")
    records, default = rule_sweep_records()
    halves = {"shared layouts": records}
    if exposure_scenes:
        halves["default palette at x0.5, x1, x2"] = [r.exposed(e) for r in collect_exposure_scenes()
                                                     for e in EXPOSURES]
        records = records + halves["default palette at x0.5, x1, x2"]
    if own_layouts:
        halves["own layouts"] = collect_palettes("tuning", own_layouts=True)
        records = records + halves["own layouts"]
    loop = [r for path in loop_views for r in evaluation.load_records(path)]
    if loop:
        halves["picking-loop views"] = loop
        records = records + loop
    features, on, scene, group, visible = verifier_rows(records, params, network)
    feature_names = tuple(feature_names or (ALL_FEATURES if network is not None else FEATURES))
    features = features[:, [ALL_FEATURES.index(name) for name in feature_names]]
    count = len(visible)
    print(f"{count} tuning scenes ({int(visible.sum())} with a visible impurity), {len(features)} regions, "
          f"{len(set(group))} palettes; features: {', '.join(feature_names)}")

    unknown = np.isnan(features).any(axis=1)
    if unknown.any():
        print(f"{int(unknown.sum())} regions with an unknown feature (NaN: read as its mean, as "
              "RegionVerifier.probability does)")

    def standardised(scaler, rows):  # an unknown value (NaN) is the fitted mean: z = 0, no contribution
        return np.nan_to_num(scaler.transform(rows), nan=0.0)

    def fit(rows, labels):
        scaler = StandardScaler().fit(rows)  # means and spreads over the known values of each feature
        model = LogisticRegression(C=1.0, max_iter=5000).fit(standardised(scaler, rows), labels)
        return scaler, model

    def predict(fitted, rows):
        scaler, model = fitted
        return model.predict_proba(standardised(scaler, rows))[:, 1]

    caps = (0.01, 0.02, 0.05)
    out_of_fold = np.zeros(len(features))
    nested = np.zeros((len(caps), 4))  # found, visible, false, clean
    for train, test in GroupKFold(n_splits=VERIFIER_FOLDS).split(features, on, group):
        fitted = fit(features[train], on[train])
        out_of_fold[test] = predict(fitted, features[test])
        own_best, _ = scene_decisions(predict(fitted, features[train]), on[train], scene[train], count)
        seen = np.zeros(count, bool)
        seen[scene[train]] = True
        test_best, test_hit = scene_decisions(out_of_fold[test], on[test], scene[test], count)
        unseen = np.zeros(count, bool)
        unseen[scene[test]] = True
        for k, cap in enumerate(caps):
            least = threshold_at(own_best[seen], visible[seen], cap)
            decided = (test_best >= least) & unseen
            nested[k] += (np.sum(decided & test_hit & visible), np.sum(unseen & visible),
                          np.sum(decided & ~visible), np.sum(unseen & ~visible))
    best, hit = scene_decisions(out_of_fold, on, scene, count)
    print("palette-grouped cross-validation, found (false TARGET) within a false-TARGET cap:")
    for k, cap in enumerate(caps):
        least = threshold_at(best, visible, cap)
        found, false = np.mean((best >= least)[visible] & hit[visible]), np.mean((best >= least)[~visible])
        print(f"  <= {100 * cap:.0f} %: out-of-fold threshold {100 * found:5.1f} % ({100 * false:.1f} %);"
              f" thresholds from the training folds {100 * nested[k, 0] / nested[k, 1]:5.1f} % "
              f"({100 * nested[k, 2] / nested[k, 3]:.1f} %)")
    fitted = fit(features, on)
    best, hit = scene_decisions(predict(fitted, features), on, scene, count)
    # the first views are the scenes before the loop views (verifier_rows keeps a scene for every record of
    # the three categories, in order); threshold_on "first-views" takes the threshold from them alone
    first = sum(r.category() in evaluation.CATEGORIES
                for r in records[:len(records) - len(loop)])
    counted = first if threshold_on == "first-views" else count
    least = threshold_at(best[:counted], visible[:counted], VERIFIER_FALSE_TARGET)
    scaler, model = fitted
    verifier = RegionVerifier(mean=tuple(round(float(v), 6) for v in scaler.mean_),
                              scale=tuple(round(float(v), 6) for v in scaler.scale_),
                              coef=tuple(round(float(v), 6) for v in model.coef_[0]),
                              intercept=round(float(model.intercept_[0]), 6), threshold=round(least, 6),
                              last_look=shipped.last_look, stall_look=shipped.stall_look,
                              low=tuple(round(float(v), 6) for v in np.nanmin(features, axis=0)),
                              high=tuple(round(float(v), 6) for v in np.nanmax(features, axis=0)),
                              features=feature_names)

    def rates(part: slice) -> str:
        shown, taken = visible[part], (best >= least)[part]
        return (f"{100 * np.mean(taken[shown] & hit[part][shown]):.1f} % found, "
                f"{100 * np.mean(taken[~shown]):.1f} % false TARGET")

    provenance = (f"scripts/calibrate_attention.py verifier-fit: {count} tuning scenes, {len(set(group))} "
                  f"palettes; on them {rates(slice(None))}")
    if loop:
        provenance = (f"scripts/calibrate_attention.py verifier-fit: {first} tuning scenes and "
                      f"{count - first} picking-loop views, {len(set(group))} palettes, threshold on "
                      f"{'the scenes' if threshold_on == 'first-views' else 'both'}; on the scenes "
                      f"{rates(slice(None, first))}, on the loop views {rates(slice(first, None))}")
    verifier = dataclasses.replace(verifier, provenance=provenance)
    print(f"fitted on all: {provenance}")
    print(f"  {verifier}")
    if model_json is not None:
        model_json.parent.mkdir(parents=True, exist_ok=True)
        model_json.write_text(json.dumps(dataclasses.asdict(verifier), indent=1))
        print(f"wrote {model_json}")
    if write:
        write_verifier(verifier, SOURCE_VERIFIER)
        print(f"wrote {SOURCE_VERIFIER} (last_look and stall_look: the shipped model's, to be matched anew)")
    if not check:
        return verifier
    print("checked through attend() on the same scenes (the shipped verifier, then the fitted one):")
    for name, tried in (("shipped", params),
                        ("fitted", dataclasses.replace(params, verifier=verifier, impurity_net=network))):
        for half, scenes in halves.items():
            print(f" {name}, {half}:")
            print_palette_rates(palette_rates(scenes, tried), per_palette=False)
    return verifier


def palette_evaluate(params: AttentionParams, json_path=None) -> dict:
    """Held-out palettes (each on scenes of its own, evaluation seeds), the retired held-out sets (acceptance
    seeds; for comparison) and the default palette at exposure x0.5, x1, x2 (acceptance seeds): only
    measured."""
    results = {"params": dataclasses.asdict(params)}
    print("== held-out palettes (each on scenes of its own: splits.HELD_OUT_LAYOUT_SEED_BASE)")
    results["held_out"] = print_palette_rates(palette_rates(collect_palettes("acceptance"), params))
    print("== retired held-out palettes, the earlier sets (acceptance seeds; measured for comparison)")
    results["retired"] = print_palette_rates(palette_rates(collect_palettes("retired"), params))
    print("== default palette (acceptance seeds), exposure x0.5 / x1 / x2")
    default = [r for r in collect("acceptance") if r.category() in ("visible", "no_impurity")]
    for exposure in EXPOSURES:
        scenes = [r.exposed(exposure) for r in default]
        results[f"default_x{exposure:g}"] = print_palette_rates(palette_rates(scenes, params))
    if json_path:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(results, indent=1))
    return results


def palette_gallery(params: AttentionParams) -> None:
    """docs/images/palettes.png: for every named palette, the camera image and the attention overlay of
    one random scene (seed 1001, two impurities): the same layout under every appearance."""
    import cv2

    from impurity_attention.core.attention import debug_image
    from impurity_learning import splits
    from ur5_driver_sim.core.appearance import PALETTES
    from ur5_driver_sim.core.world import CellWorld

    world = CellWorld(mode="floating")
    tiles = []
    for name in PALETTES:
        record, frame = evaluation.record_from_world(world, "random", 1001, 2, NUM_OBJECTS, keep_frame=True,
                                                     palette=name)
        output = attend(record.color, record.height, params)
        camera = cv2.resize(frame.color, (298, 224), interpolation=cv2.INTER_AREA)[:, 37:261]
        overlay = debug_image(record.color, output)
        pair = np.concatenate([camera, overlay], axis=1).copy()
        label = f"{name} ({splits.palette_group(name)}): {output.mode.name} {output.score:.1f}"
        cv2.putText(pair, label, (4, 218), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
        tiles.append(pair)
    world.close()
    while len(tiles) % 3:
        tiles.append(np.zeros_like(tiles[0]))
    rows = [np.concatenate(tiles[i:i + 3], axis=1) for i in range(0, len(tiles), 3)]
    IMAGES.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(IMAGES / "palettes.png"), cv2.cvtColor(np.concatenate(rows, axis=0), cv2.COLOR_RGB2BGR))
    print(f"wrote {IMAGES / 'palettes.png'}")


def read_network_option(value: pathlib.Path | None):
    """--network: None, "shipped" (impurity_net.SHIPPED_NETWORK) or a weights file, read."""
    if value is None:
        return None
    from impurity_attention.core.impurity_net import NetworkFileError, read_network
    try:
        return read_network(None if str(value) == "shipped" else value)
    except NetworkFileError as error:
        raise SystemExit(f"--network: {error}") from error


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("collect", "sweep", "evaluate", "gallery", "lab-reference",
                                           "palette-evaluate",
                                           "palette-gallery", "network-fit", "verifier-fit"))
    parser.add_argument("--split", choices=tuple(SEED_BASE), default="tuning")
    parser.add_argument("--limit", type=int, default=None, help="only the first N scenes of the split")
    parser.add_argument("--json", type=pathlib.Path, default=None, help="write the summary here")
    parser.add_argument("--verbose", action="store_true", help="list every miss")
    parser.add_argument("--depth-noise", type=float, default=0.0,
                        help="Gaussian depth noise of the sim camera (m), e.g. 0.002 for a RealSense")
    parser.add_argument("--own-layouts", action="store_true",
                        help="verifier-fit: also the tuning palettes' own-layout scenes (collect_palettes)")
    parser.add_argument("--loop-views", type=pathlib.Path, nargs="*", default=(),
                        help="verifier-fit: also these picking-loop views (.npz scene records, "
                             "docs/experiments_s17/loop_views.py)")
    parser.add_argument("--model-json", type=pathlib.Path, default=None,
                        help="verifier-fit: also write the fitted model here as JSON")
    parser.add_argument("--threshold-on", choices=("all", "first-views"), default="all",
                        help="verifier-fit: the scenes the threshold's false-TARGET share is counted on")
    parser.add_argument("--features", default=None,
                        help="verifier-fit: the model's features, comma-separated names of "
                             "verifier.ALL_FEATURES "
                             "(default all; before the twentieth session: every one but oriented_*)")
    parser.add_argument("--no-check", action="store_true",
                        help="verifier-fit: skip the check through attend() after the fit")
    parser.add_argument("--write-model", action="store_true",
                        help="verifier-fit: write the fitted model to impurity_attention/checkpoints/"
                             "verifier.json")
    parser.add_argument("--epochs", type=int, default=NETWORK_EPOCHS, help="network-fit: training epochs")
    parser.add_argument("--write-network", action="store_true",
                        help="network-fit: write the network to "
                             "impurity_attention/checkpoints/impurity_net.pt "
                             f"(else {NETWORK_OUT.relative_to(ROOT)})")
    parser.add_argument("--positive-weight", type=float, default=None,
                        help="network-fit: an impurity cell's weight in the loss (default "
                             "impurity_net_training.POSITIVE_WEIGHT, 5)")
    parser.add_argument("--network-out", type=pathlib.Path, default=None,
                        help="network-fit: write the network here (instead of the default or "
                             "--write-network)")
    parser.add_argument("--no-invisible", action="store_true",
                        help="network-fit: leave the invisible-layout scenes out (their impurities are "
                             "cubes)")
    parser.add_argument("--network", type=pathlib.Path, default=None,
                        help="verifier-fit: the impurity network whose map the rows read (NETWORK_FEATURES; "
                             "'shipped': impurity_attention's); without it the model leaves them out")
    parser.add_argument("--patch-prism-winding", action="store_true",
                        help="work around the sim's inward-wound prism mesh (see patch_prism_winding)")
    args = parser.parse_args()
    params = AttentionParams()
    suffix = ""
    if args.patch_prism_winding:
        patched = patch_prism_winding()
        suffix = "_prismfix" if patched else ""
        print("prism mesh winding patched in this process" if patched else "prism mesh already outward")

    if args.action == "gallery":
        gallery(params)
        return
    if args.action == "palette-evaluate":
        palette_evaluate(params, args.json)
        return
    if args.action == "palette-gallery":
        palette_gallery(params)
        return
    if args.action == "network-fit":
        from impurity_attention.core.impurity_net import SHIPPED_NETWORK
        out = args.network_out or (SHIPPED_NETWORK if args.write_network else NETWORK_OUT)
        network_fit(params, args.epochs, out, invisible=not args.no_invisible,
                    positive_weight=args.positive_weight)
        return
    if args.action == "verifier-fit":
        verifier_fit(params, args.write_model, args.own_layouts, check=not args.no_check,
                     loop_views=tuple(args.loop_views),
                     model_json=args.model_json, threshold_on=args.threshold_on,
                     feature_names=tuple(args.features.split(",")) if args.features else None,
                     network=read_network_option(args.network))
        return
    if args.depth_noise > 0:
        suffix += f"_noise{args.depth_noise * 1000:g}mm"
    split = args.split if args.action != "sweep" else "tuning"
    records = collect(split, args.limit, suffix, args.depth_noise)
    print(f"{len(records)} {split} scenes")
    if args.action == "sweep":
        sweep(records)
    elif args.action == "lab-reference":
        from impurity_attention.core.colour_adaptation import lab_statistics
        seen = [r.labels != -1 for r in records]  # unseen cells are black, not scene colour
        stats = lab_statistics([r.color for r in records], seen)
        print("reference Lab statistics of sim heightmaps (heightmap_node colour_reference_mean/std):")
        print(f"  mean {[round(v, 2) for v in stats.mean]}  std {[round(v, 2) for v in stats.std]}")
    elif args.action == "evaluate":
        verdicts, times = evaluate(records, params, args.verbose)
        summary = print_summary(verdicts, times)
        if args.json:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps({"split": args.split, "params": dataclasses.asdict(params),
                                             "summary": summary,
                                             "verdicts": [v.as_dict() for v in verdicts]}, indent=1))


if __name__ == "__main__":
    main()
